// Private to NeuralVolume::Filters: the engine-facing half of vtkNeuralCompress. Keeps the engine
// headers out of the wrapped public header (the way vtkONNXInference hides its runtime).
#ifndef vtkNeuralCompressInternals_h
#define vtkNeuralCompressInternals_h

#include "Core/Engine.h"
#include "Core/Model.h"
#include "Core/NetworkSession.h"
#include "Core/Volume.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

class vtkDataArray;

namespace vtkNeuralCompressInternals
{

/// A single-component view of the selected array, with the copy that backs it when the array
/// could not be used in place (vectors, non-contiguous layouts, bit arrays).
struct SourceField
{
  nv::VolumeView View;
  std::vector<unsigned char> Storage;
  int64_t RawBytes = 0;     ///< bytes of the field in the input's native type
  std::string Description;  ///< e.g. "magnitude of 3 components"
};

/// Fill `field` from `array` (nTuples must equal dims[0]*dims[1]*dims[2]). Returns false and sets
/// `error` when the array cannot be represented.
bool MakeSourceField(vtkDataArray* array, int vectorMode, int component, const int64_t dims[3],
  SourceField& field, std::string& error);

/// Geometry of the decoded output for an input of extent/origin/spacing and a requested
/// resolution (samples per axis; 0 = the source's). For a point array the samples are the
/// output's points; for a cell array they are its cells.
struct OutputGeometry
{
  int Extent[6];
  double Origin[3];
  double Spacing[3];
  int SourceDims[3];  ///< samples per axis of the trained field (points or cells)
  int DecodedDims[3]; ///< samples per axis of the decoded output
  bool OnSourceGrid;  ///< decoded samples coincide with the source samples
};
OutputGeometry ComputeGeometry(
  const int ext[6], const double origin[3], const double spacing[3], bool cells, const int res[3]);

struct LogRow
{
  int64_t Step;
  double Loss;
  double LearningRate;
  double ElapsedSeconds;
  double PSNR; ///< NaN when not evaluated at this step
};

/// Estimates the PSNR of a model on a fixed random subset of valid voxels.
class PsnrProbe
{
public:
  PsnrProbe(const nv::VolumeView& view, uint64_t seed, int64_t maxSamples);
  /// On a bank of training points (xyz in [0,1]^3, normalised values; non-finite ones skipped): every
  /// max(1, count / maxSamples)-th point.
  PsnrProbe(const std::vector<float>& xyz, const std::vector<float>& values, int64_t maxSamples);
  /// Estimate from the session's current (published) network.
  double Estimate(nv::NetworkSession& session) const;

private:
  std::vector<float> Coords;   // xyz interleaved in [0,1]
  std::vector<float> Expected; // normalised source values
};

struct TrainingRequest
{
  int64_t MaxSteps = 0;
  double TimeBudget = 0.0; ///< seconds, 0 = unlimited
  int PsnrInterval = 0;
  std::function<bool()> ShouldAbort;
  std::function<void(double)> Progress;
};

struct TrainingResult
{
  int64_t Steps = 0;
  double Seconds = 0.0;
  double FinalLoss = 0.0;
  bool Aborted = false;
  bool TimedOut = false;
  int64_t DeviceMemoryBytes = 0; ///< GPU memory held by the trainer (0 on the CPU)
  std::vector<LogRow> Log;
};

/// Trains the session's network on `view`; the trained parameters are published to the session (probes publish
/// on their steps). Engine errors propagate as nv::Error.
TrainingResult Train(nv::NetworkSession& session, const nv::VolumeView& view, const nv::TrainConfig& config,
  const TrainingRequest& request, const PsnrProbe* probe);

/// PSNR (dB) from a mean squared error of normalised values; +inf for an exact match.
double PsnrFromMse(double mse);

} // namespace vtkNeuralCompressInternals

#endif
