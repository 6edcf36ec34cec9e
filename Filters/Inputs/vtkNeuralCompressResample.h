// Neural Compress on datasets that are not images (private header): rectilinear, structured, unstructured grids,
// poly data with volume cells, composite datasets (multiblock, partitioned collections) and AMR are resampled once
// onto an image covering their bounds with VTK's vtkResampleToImage (point location and interpolation inside the
// source cells by VTK; overlapping AMR: the finest level that covers a point wins). Image points outside the
// domain get NaN, so the engine never trains on them and the decoded output marks them NaN.
#ifndef vtkNeuralCompressResample_h
#define vtkNeuralCompressResample_h

#include "vtkNeuralCompressParticles.h"
#include "vtkSmartPointer.h"
#include "vtkType.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

class vtkDataArray;
class vtkDataObject;
class vtkDataSet;
class vtkImageData;

namespace vtkNeuralCompressInternals
{
struct SourceSamples;

/// The leaves of `input` (the dataset itself when it is not composite).
std::vector<vtkDataSet*> InputLeaves(vtkDataObject* input);

/// The scalar the network learns from tuple i of `array`: its value (one component), or of a vector its magnitude
/// (vectorMode 0) or component `component` (vectorMode 1, clamped to the array's components).
double TupleScalar(vtkDataArray* array, vtkIdType i, int vectorMode, int component);

/// Probe points `first` .. `first + count - 1` of the bank's seeded stream in the box (lo, len): normalised to the box
/// as the network's inputs are (`unit`, 0.5 on a flat axis) and in world coordinates (`world`), 3 values each.
void RandomBoxPoints(const double lo[3], const double len[3], uint64_t seed, int64_t first, int64_t count,
  float* unit, double* world);

/// Probe sampling's bank: random points of the resampled image's box that lie inside the source's cells, with the
/// scalar the network learns there.
struct ProbedBank
{
  std::vector<float> Xyz;     ///< interleaved, normalised to the image's box ([0,1]; 0.5 on a flat axis)
  std::vector<double> Values; ///< source units (magnitude or component as the VectorMode says)
  int64_t Probed = 0;         ///< points probed (inside and outside the domain)
  double Seconds = 0.0;       ///< time the probing took
};

/// Samples per axis for resampling an input of `bounds` with `sourceSamples` points or cells (finestSpacing > 0:
/// composites of images such as AMR: their finest spacing): about 27 image points per source sample (or that spacing),
/// between 32^3 and 256^3 in all, shared between the axes in proportion to the extents (a flat axis gets 1).
void AutoSamplingDimensions(const double bounds[6], int64_t sourceSamples, double finestSpacing, int dims[3]);

/// The samples per axis a non-image input is resampled at: `requested`, or AutoSamplingDimensions where it is
/// 0 0 0. False with `problem` set when the input has no such array or no volume for it (e.g. poly data of
/// surfaces only).
bool ResolveSamplingDimensions(vtkDataObject* input, const std::string& name, int association,
  const int requested[3], int dims[3], std::string& problem);

/// A stamp of what a non-image input's field is made of: every leaf dataset, its points and cells and the array
/// `name` (their pointers and modification times). It changes when the pipeline gives the filter new data, and not
/// when only the input's container or information is touched (e.g. by a locator built in a leaf).
uint64_t InputStamp(vtkDataObject* input, const std::string& name, int association);

/// The bounds of every leaf dataset of `input` together; false (bounds untouched) when it has no points.
bool InputBounds(vtkDataObject* input, double bounds[6]);

/// The resampled field of a non-image input; reused while the input, the array and the dimensions stay the same
/// (the filter re-executes for live refreshes during training).
class InputResampler
{
public:
  /// Resamples array `name` (point or cell association, any number of components) of `input` at `dims`
  /// (ResolveSamplingDimensions). On success `image` holds the array as point data (float32 or float64, NaN
  /// outside the domain) and `outside` counts those points. False with `problem` set when the input has no such
  /// array or no volume for it (e.g. poly data of surfaces only).
  /// `source` and `sourceMTime` identify the input for the cache (the pipeline's object when `input` is a copy of it).
  bool Resample(vtkDataObject* input, const std::string& name, int association, const int dims[3],
    vtkSmartPointer<vtkImageData>& image, int64_t& outside, std::string& problem, const void* source,
    vtkMTimeType sourceMTime);

  /// Wall seconds per image sample of the last resampling (0 before one).
  double SecondsPerSample() const { return this->PerSample; }
  /// Seconds a probe of this input costs before its first point (its cell locator), as measured by a small
  /// resampling (0: not measured).
  double SetupSeconds() const { return this->Setup; }
  void SetSetupSeconds(double seconds) { this->Setup = seconds; }

  /// The source's own samples of the last resampled input (points or visible cell centres) with the scalar the
  /// network learns from them (vectorMode 0: magnitude, 1: `component`), for measuring the PSNR at the source.
  std::shared_ptr<const SourceSamples> Samples(int vectorMode, int component);

  /// Probe sampling: `count` random points (seeded) of the last resampled image's box probed inside the source's cells
  /// (vtkCompositeDataProbeFilter with a vtkStaticCellLocator); those inside the domain form the bank. Cached while the
  /// input, array, count, seed and vector mode stay the same. Null with `problem` set when no point is inside.
  std::shared_ptr<const ProbedBank> Probe(int64_t count, uint64_t seed, int vectorMode, int component,
    std::string& problem);

  /// Particle sets (vtkNeuralCompressParticles.h): how their field is reconstructed; part of the cache key.
  void SetParticleSettings(const ParticleSettings& settings) { this->Particles = settings; }

  /// A one-line description of the last resampled input ("vtkUnstructuredGrid, 7472 cells -> 64 x 64 x 113").
  const std::string& Description() const { return this->Text; }

private:
  // Particle sets (defined in vtkNeuralCompressParticles.cxx): the image, the particles' own samples, the bank.
  bool ResampleParticles(vtkDataObject* input, const std::string& name, int association, const int dims[3],
    std::string& problem);
  std::shared_ptr<const SourceSamples> ParticleSamples();
  std::shared_ptr<const ProbedBank> ProbeParticles(
    int64_t count, uint64_t seed, int vectorMode, int component, std::string& problem);
  /// A new bank kept as Probe's cache (its key: count, seed, vector mode, component); returns it.
  std::shared_ptr<const ProbedBank> KeepBank(
    std::shared_ptr<const ProbedBank> bank, int64_t count, uint64_t seed, int vectorMode, int component);

  const void* Input = nullptr;
  vtkMTimeType InputMTime = 0;
  vtkSmartPointer<vtkDataObject> Source; ///< the object resampled (its cells are probed by Probe)
  double PerSample = 0.0;
  double Setup = 0.0;
  std::string Name;
  int Association = -1;
  int Dims[3] = { 0, 0, 0 };
  vtkSmartPointer<vtkImageData> Image;
  int64_t Outside = 0;
  int SamplesMode = -1, SamplesComponent = -1;
  std::shared_ptr<const SourceSamples> Cached;
  std::shared_ptr<const ProbedBank> Bank;
  int64_t BankCount = 0;
  uint64_t BankSeed = 0;
  int BankMode = -1, BankComponent = -1;
  std::string Text;
  ParticleSettings Particles, ResampledParticles;
  std::shared_ptr<const nv::ParticleField> ParticleSet; ///< the last input's, when it is a particle set
  int64_t ParticleBytes = 0;
};

} // namespace vtkNeuralCompressInternals

#endif
