// Neural Compress under MPI with one network per rank (private header; vtkNeuralCompressPartition.h): the whole
// field's figures from every rank's sums. Each rank measures its network against its own samples -- the samples of
// its owned piece, each sample of the whole field counted on exactly one rank (a shared boundary plane belongs to the
// upper piece, the whole extent's last plane to the last) -- and one all-reduce gives every rank the same
// NeuralPSNR (10 log10(span^2 count / sum of squared errors), span the whole field's value range), NeuralMaxError
// (max), NeuralModelBytes (sum) and NeuralCompressionRatio (the whole field's bytes over the summed model bytes).
#ifndef vtkNeuralCompressGlobalFigures_h
#define vtkNeuralCompressGlobalFigures_h

#include <cstdint>

class vtkImageData;
class vtkTable;

namespace nv
{
struct ErrorStats;
class NetworkSession;
struct VolumeView;
}

namespace vtkNeuralCompressInternals
{

/// One rank's contribution (all zero, Networks 0, for a rank without a network).
struct PieceSums
{
  double SquaredError = 0.0; ///< source units squared
  double Count = 0.0;        ///< finite source samples measured
  double MaxError = 0.0;     ///< source units
  double ValueMin = 0.0, ValueMax = 0.0; ///< of the samples measured (valid when Count > 0)
  double NonFinite = 0.0;    ///< samples whose decoded value is NaN or Inf
  double ModelBytes = 0.0;
  double FieldBytes = 0.0;   ///< raw bytes of the samples measured, in the input's type
  double Networks = 0.0;     ///< 1 when this rank has a network
  double Samples = 0.0;      ///< samples this rank owns exclusively (finite or not)
  double WholeSamples = 0.0; ///< samples of the whole extent (points, or cells of a cell array)
  double Failed = 0.0;       ///< 1 when this rank held a piece but could not train it (it reported why)
  double Estimated = 0.0;    ///< 1 while this rank trains in the background: SquaredError from its PSNR estimate
  double Unknown = 0.0;      ///< 1 when that estimate is not known yet (no probe so far)
};

/// The whole field's figures (the same on every rank).
struct GlobalFigures
{
  double Psnr = 0.0;
  double MaxError = 0.0;
  double MaxErrorOfRange = 0.0;
  double Ratio = 0.0;
  double ModelBytes = 0.0;
  double Count = 0.0;
  int Networks = 0;
  double Samples = 0.0, WholeSamples = 0.0; ///< owned by the ranks together, and of the whole extent
  int Failed = 0;                           ///< ranks that held a piece and could not train it
  double PiecePsnr = 0.0; ///< this rank's own samples against the whole field's range
  bool Estimated = false; ///< some rank still trains: Psnr from the ranks' estimates (NaN until each has one),
                          ///< MaxError unknown (NaN)
};

/// The samples of a training grid (`dims` samples, sample (0,0,0) at point/cell index trainExtent[0,2,4]) that
/// `owned` holds exclusively: lo..hi per axis (inclusive, grid indices), their count and the whole extent's (`samples`,
/// `wholeSamples`); false when the grid holds none of them.
bool ExclusiveSamples(const int trainExtent[6], const int64_t dims[3], const int owned[6], const int whole[6],
  bool cells, int lo[3], int hi[3], double& samples, double& wholeSamples);

/// This rank's sums from a measurement of its exclusive samples whose figures are normalised by the network's range
/// valueMin..valueMax (nv::ErrorStats: an out-of-core piece measured on the file, vtkNeuralOutOfCoreInput.h);
/// `valueMin`, `valueMax` also stand for the measured samples' range (the ranks' maxima give the whole field's).
PieceSums SumsOfMeasurement(const nv::ErrorStats& error, double valueMin, double valueMax, double samples,
  double wholeSamples, double rawBytesPerSample, double modelBytes);

/// This rank's sums: the session's network decoded over the exclusively owned samples of `view` (the field the
/// network was trained on, sample (0,0,0) at point/cell index trainExtent[0,2,4]); `owned` and `whole` are point
/// extents; `rawBytesPerSample` the input type's size.
PieceSums MeasurePiece(nv::NetworkSession& session, const nv::VolumeView& view, const int trainExtent[6],
  const int owned[6], const int whole[6], bool cells, double rawBytesPerSample, double modelBytes);

/// While this rank trains in the background (TrainInBackground under MPI): its sums estimated from its live PSNR
/// estimate `psnr` (over its training field's range `valueMin`..`valueMax`; NaN: none yet) for the samples it owns.
PieceSums EstimatePiece(const int owned[6], const int whole[6], bool cells, double psnr, double valueMin,
  double valueMax, double rawBytesPerSample, double modelBytes);

/// The all-reduce (a collective: every rank calls it once per execution, with or without a network).
GlobalFigures ReduceFigures(const PieceSums& local);

/// The global figures into the output's field data (NeuralPSNR, NeuralMaxError, NeuralMaxErrorOfRange,
/// NeuralCompressionRatio, NeuralModelBytes replaced; NeuralPiecePSNR this rank's own (PiecePsnr), NeuralNetworks the count) and
/// the metrics table's last row.
void WriteGlobalFigures(vtkImageData* output, vtkTable* metrics, const GlobalFigures& global);

} // namespace vtkNeuralCompressInternals

#endif
