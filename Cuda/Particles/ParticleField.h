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
// Radii that differ widely (adaptive smoothing lengths, a few huge radii): the locator files the particles by radius
// class -- radii within a factor 2 of each other, at most kRadiusClasses classes, the smallest radii sharing the last
// -- in one grid per class whose cells are the class's largest radius. A query visits at most 27 cells of each grid,
// so the particles it visits have supports about as large as those cells: a few huge radii cost a few visits, not a
// visit of every particle (a single grid of the largest radius made every query read most of the set). A radius above
// kMaxRadiusExtents times the box's largest extent is clamped to it and counted (ParticleCounts::ClampedRadius): such
// a particle's kernel is flat over the box (within 1e-5 of its centre value) and its weight would underflow float.
#pragma once

#include "ParticleGrid.h"
#include "ParticleKernel.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

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
/// Radius classes of the locator (a factor 2 apart: radii 2^11 = 2048 times below the largest share the last).
constexpr int kRadiusClasses = 12;
/// Radii are clamped to this many times the largest extent of the particles' box.
constexpr double kMaxRadiusExtents = 1000.0;

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
  int64_t ClampedRadius = 0; ///< used, with the radius clamped to kMaxRadiusExtents box extents
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

  /// The kernel sums at count points (interleaved xyz), in the data's units: weighted[i] = sum_j f_j W_j(x_i) and
  /// weights[i] = sum_j W_j(x_i), both 0 outside every support. The field is weighted / weights (Interpolate) or
  /// weighted (Density) where weights > 0, and the sums of fields built on disjoint parts of one particle set (the
  /// same radii) add up to the whole set's: how the ranks of a distributed set combine their particles' sums.
  void kernelSums(const double* xyz, int64_t count, double* weighted, double* weights, int threads) const;

  const ParticleCounts& counts() const { return this->Counts; }
  const ParticleOptions& options() const { return this->Options; }
  /// The box of the particles used (finite positions), xmin xmax ymin ymax zmin zmax.
  const double* bounds() const { return this->Bounds; }
  double meanSpacing() const { return this->Spacing; }
  double maxRadius() const { return this->MaxRadius; }
  double minRadius() const { return this->MinRadius; }
  /// Bytes the locator holds (records and cell starts of every radius class).
  int64_t locatorBytes() const;
  /// The radius classes the locator holds a grid for (1 when every radius is the same).
  int radiusClasses() const { return int(this->Grids.size()); }
  /// The particles the locator visits for a query at world point x (inside or not of their supports): the work of
  /// evaluate(x), for tests and cost estimates.
  int64_t candidates(const double x[3]) const;
  /// "200000 particles, cubic spline, radius 0.031 (automatic: 2 x mean spacing 0.0155), interpolated".
  std::string describe() const;

private:
  std::vector<ParticleRecord> Gather(const ParticleInput& input);
  void BuildLocator(std::vector<ParticleRecord> records, const double extent[3]);
  /// The kernel sums at world point x in the records' units (1 / R^3 in box units).
  void sumsAt(const double x[3], double& sumWeighted, double& sumWeight) const;
  template <class Visit>
  void forEachNear(const double u[3], Visit&& visit) const
  {
    for (size_t g = 0; g < this->Grids.size(); ++g)
      this->Grids[g]->forEachNear(u, this->GridReach[g], visit);
  }

  ParticleOptions Options;
  ParticleCounts Counts;
  double Bounds[6] = { 0, 0, 0, 0, 0, 0 };
  double Spacing = 0.0, MaxRadius = 0.0, MinRadius = 0.0;
  double Scale = 1.0;           ///< world -> the records' units (1 / the box's largest extent)
  double ScaledMaxRadius = 0.0; ///< MaxRadius in the records' units
  bool AutomaticRadius = false;
  std::vector<std::unique_ptr<ParticleGrid>> Grids; ///< one per radius class, largest radii first
  std::vector<double> GridReach;                    ///< the largest radius of each grid's particles (records' units)
  size_t OrderGrid = 0;                             ///< the grid with the most particles (query order)
};

} // namespace nv
