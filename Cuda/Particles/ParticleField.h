// NeuralVolume engine: the continuous field a set of particles defines, evaluated on the fly at any point through
// a uniform-grid locator (ParticleGrid.h); never splatted to a dense grid. Two reconstructions (ParticleFieldMode):
//   Interpolate: sum_i f_i W_i(x) / sum_i W_i(x)  (normalised, SPH/Shepard style, as vtkSPHInterpolator with
//                Shepard normalisation computes it);
//   Density:     sum_i f_i W_i(x)                  (f_i a mass or any extensive quantity, as OpenVKL's particle volume),
// with W_i(x) = particleKernel(|x - p_i| / R_i) / R_i^3 (ParticleKernel.h). Outside every particle's support
// (|x - p_i| >= R_i for all i) the field is empty: evaluate() says so and evaluateMany() gives NaN there.
// Particles with a non-finite position or value, or a radius that is not finite and positive, are skipped and
// counted (ParticleCounts); a set with none left, or whose particles all lie at one point when the radius is
// automatic, is refused (nv::Error).
#pragma once

#include "ParticleGrid.h"
#include "ParticleKernel.h"

#include <cstdint>
#include <memory>
#include <string>

namespace nv
{

enum class ParticleFieldMode : int
{
  Interpolate = 0,
  Density = 1
};

struct ParticleOptions
{
  ParticleFieldMode Mode = ParticleFieldMode::Interpolate;
  ParticleKernel Kernel = ParticleKernel::CubicSpline;
  /// Support radius of every particle when the input has no radius array; 0: automatic, kAutoRadiusSpacings times
  /// the mean particle spacing (meanParticleSpacing).
  double Radius = 0.0;
};

/// The automatic radius in mean particle spacings (about 33 neighbours within the support of a uniform set).
constexpr double kAutoRadiusSpacings = 2.0;

/// count particles: positions (interleaved xyz), values, optional per-particle support radii (null: Options.Radius).
struct ParticleInput
{
  const double* Xyz = nullptr;
  const double* Values = nullptr;
  const double* Radii = nullptr;
  int64_t Count = 0;
};

struct ParticleCounts
{
  int64_t Used = 0, BadPosition = 0, BadValue = 0, BadRadius = 0;
};

class ParticleField
{
public:
  /// Builds the locator; throws nv::Error for a set it cannot reconstruct (see above).
  ParticleField(const ParticleInput& input, const ParticleOptions& options);

  /// The field at world point x; false (value untouched) outside every particle's support.
  bool evaluate(const double x[3], double& value) const;
  /// The field at count points (interleaved xyz) into values, NaN outside the support; `threads` <= 0: every core.
  /// Returns the number of points inside the support.
  int64_t evaluateMany(const double* xyz, int64_t count, double* values, int threads) const;

  const ParticleCounts& counts() const { return this->Counts; }
  const ParticleOptions& options() const { return this->Options; }
  /// The box of the particles used (finite positions), xmin xmax ymin ymax zmin zmax.
  const double* bounds() const { return this->Bounds; }
  double meanSpacing() const { return this->Spacing; }
  double maxRadius() const { return this->MaxRadius; }
  double minRadius() const { return this->MinRadius; }
  int64_t locatorBytes() const { return this->Grid ? this->Grid->bytes() : 0; }
  /// "200000 particles, cubic spline, radius 0.031 (automatic: 2 x mean spacing 0.0155), interpolated".
  std::string describe() const;

private:
  std::vector<ParticleRecord> Gather(const ParticleInput& input);

  ParticleOptions Options;
  ParticleCounts Counts;
  double Bounds[6] = { 0, 0, 0, 0, 0, 0 };
  double Spacing = 0.0, MaxRadius = 0.0, MinRadius = 0.0;
  double Scale = 1.0;           ///< world -> the records' units (1 / the box's largest extent)
  double ScaledMaxRadius = 0.0; ///< MaxRadius in the records' units
  bool AutomaticRadius = false;
  std::unique_ptr<ParticleGrid> Grid;
};

} // namespace nv
