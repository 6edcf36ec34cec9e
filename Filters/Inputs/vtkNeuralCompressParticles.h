// Neural Compress on particles (private header): a point cloud -- poly data of vertices or points only, an
// unstructured grid of VTK_VERTEX / VTK_POLY_VERTEX cells, or a composite of them -- with a point scalar is the
// continuous field of the engine's kernel reconstruction (Particles/ParticleField.h), evaluated on the fly through
// its locator: at the samples of the image the field is decoded on (NaN outside every particle's support, the domain
// mask), at the random points of the Probe bank and at the particles themselves (the error figures). This file only
// translates VTK data to the engine's and back (InputResampler's particle members are defined here).
#ifndef vtkNeuralCompressParticles_h
#define vtkNeuralCompressParticles_h

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

class vtkDataObject;

namespace nv
{
class ParticleField;
}

namespace vtkNeuralCompressInternals
{

/// The filter's particle properties (vtkNeuralCompress::ParticleField...), with the vector mode that picks the scalar.
struct ParticleSettings
{
  int Field = 0;           ///< nv::ParticleFieldMode: 0 interpolate, 1 density
  int Kernel = 1;          ///< nv::ParticleKernel: 0 Gaussian, 1 cubic spline, 2 Wendland C2
  double Radius = 0.0;     ///< constant support radius; 0: automatic
  std::string RadiusArray; ///< a point array of per-particle support radii; empty: Radius
  int VectorMode = 0, VectorComponent = 0;
  bool operator==(const ParticleSettings& o) const
  {
    return Field == o.Field && Kernel == o.Kernel && Radius == o.Radius && RadiusArray == o.RadiusArray &&
      VectorMode == o.VectorMode && VectorComponent == o.VectorComponent;
  }
  bool operator!=(const ParticleSettings& o) const { return !(*this == o); }
};

/// True when every leaf of `input` with points is a particle set (no lines, polygons, strips or volume cells) and
/// one at least has points.
bool IsParticleSet(vtkDataObject* input);

/// The samples per axis of a particle set's image: `requested`, or automatic (about 8 samples per particle over the
/// box of its finite positions, 32^3 to 256^3). False with `problem` set when the point array `name` is missing, the
/// association is not points, or the particles span no box.
bool ResolveParticleDimensions(vtkDataObject* input, const std::string& name, int association,
  const int requested[3], int dims[3], std::string& problem);

/// A particle set's arrays as the engine reads them: positions (interleaved xyz), the scalar (its magnitude or a
/// component as the settings say) and the radii when ParticleRadiusArray names them, as doubles; the bytes a user
/// counts for the particles (positions and the scalar, in their own types).
struct ParticleArrays
{
  std::vector<double> Xyz, Values, Radii;
  int64_t SourceBytes = 0;
};

/// Fills `arrays` from every leaf of `input` with point array `name`; false with `problem` when a leaf lacks the
/// radius array.
bool CollectParticles(vtkDataObject* input, const std::string& name, const ParticleSettings& settings,
  ParticleArrays& arrays, std::string& problem);

/// The engine's particle field of array `name` (its magnitude or a component as the settings say) and the bytes a
/// user counts for the particles (positions and the scalar, in their own types). Null with `problem` set when it
/// cannot be built (no array, bad particles only, all at one point with an automatic radius).
std::shared_ptr<const nv::ParticleField> BuildParticleField(vtkDataObject* input, const std::string& name,
  const ParticleSettings& settings, int64_t& sourceBytes, std::string& problem);

} // namespace vtkNeuralCompressInternals

#endif
