// Private to NeuralVolume::Filters: what vtkNeuralCompress keeps between executions -- the training job of the
// current time step (its session, its run, the result of its last phase) and the records of its networks (the
// networks of other time steps: vtkNeuralCompressNetworkCache.h).
#ifndef vtkNeuralCompressJob_h
#define vtkNeuralCompressJob_h

#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressSettings.h"
#include "vtkNeuralNetworkArray.h"

#include "vtkSmartPointer.h"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

class vtkDataArray;

namespace vtkNeuralCompressInternals
{

/// The user's numbers for one network (field data of output 0, a row of the metrics table).
struct Metrics
{
  std::string State;   ///< Training, Paused, Finished, Stopped, Restored, ...
  int64_t Steps = 0;
  double Seconds = 0.0;
  double Psnr = std::numeric_limits<double>::quiet_NaN(); ///< dB over every source sample (an estimate while training)
  bool PsnrFinal = false;
  double MaxError = std::numeric_limits<double>::quiet_NaN(); ///< source units (inf where it exceeds DBL_MAX)
  double MaxErrorOfRange = std::numeric_limits<double>::quiet_NaN(); ///< MaxError / (max - min), always finite
  /// Resampled inputs: Psnr and MaxError are measured at the source's own samples (SourceSamples); this is the PSNR
  /// on the resampled image the network was trained on. NaN for image inputs.
  double ResampledPsnr = std::numeric_limits<double>::quiet_NaN();
  int64_t SourceSamples = 0; ///< samples the source PSNR was measured at (0: image input)
  double Ratio = 0.0;
  int64_t ModelBytes = 0;
  int64_t Invalid = 0;
  int64_t DeviceMemoryBytes = 0;
  std::string Device;
  int CudaDevice = -1; ///< the GPU ordinal of the session (NeuralCudaDevice; -1: the CPU, or not known)
  bool WarmStart = false;
  bool Restored = false;
  std::string EndReason;
  double ErrorBound = 0.0;  ///< the error-bounded mode's bound (data units); 0: off
  int64_t Corrections = 0;  ///< samples the network stores a correction for (ErrorBound > 0)
  std::string ErrorBoundNote; ///< why MaxError was not kept for this network (empty: it was, or it is off)
};

/// The figures a stored network carries (its training statistics), for a network taken from a state file, the
/// cache or a .nvol file; `device`: where it is used now.
Metrics MetricsOf(const nv::Model& model, const std::string& device);

/// Serialized network bytes (nv::serialize) as the output's NeuralNetwork array, made once and never changed: live
/// refreshes, re-executions, the cache and state files share them without a copy.
using NetworkBytes = std::shared_ptr<const vtkNeuralNetworkArray::SharedNetwork>;
inline NetworkBytes ShareBytes(const std::vector<uint8_t>& bytes)
{
  return vtkNeuralNetworkArray::Share(bytes);
}
inline bool HasBytes(const NetworkBytes& bytes)
{
  return bytes && bytes->size() > 0;
}

/// A network of one time step, as it is cached and saved with a state file.
struct NetworkRecord
{
  uint64_t Key = 0;
  double Time = 0.0;
  NetworkBytes Bytes; ///< stored precision; null while a training job installs its first network
  Metrics Figures; ///< the numbers the user sees for this network
  std::vector<LogRow> Log;
};

/// What the selected array is, where its output goes.
/// The source's own samples of a resampled input (points, or cell centres; AMR: the visible cells), at most
/// kMaxSourceSamples of them (an even stride through them beyond): the final PSNR is measured there, with the network
/// evaluated at each, not on the resampled image.
struct SourceSamples
{
  static constexpr int64_t kMaxSourceSamples = 1 << 21;
  std::vector<double> Xyz;    ///< world coordinates, interleaved
  std::vector<double> Values; ///< the trained scalar (magnitude or component as the VectorMode says)
  int64_t Total = 0;          ///< samples of the source (before the stride)
  int64_t SourceBytes = 0;    ///< bytes of the selected array in every block (the compression ratio's numerator)
};

struct OutOfCoreFile;

struct FieldInfo
{
  std::string Name;
  bool Cells = false;
  int VtkType = 0;
  std::string Description;
  OutputGeometry Geometry;
  nv::VolumeStats Stats;
  double Direction[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
  int InputExtent[6] = { 0, 0, 0, 0, 0, 0 };
  double InputOrigin[3] = { 0, 0, 0 };
  double InputSpacing[3] = { 1, 1, 1 };
  /// MPI, a rank's piece (vtkNeuralCompressPartition.h): the extent it owns and the whole extent, in the index frame of
  /// InputOrigin and InputSpacing; empty in a serial run. The output lattice is then the whole one
  /// (PieceOfWholeGeometry).
  int PieceOwned[6] = { 0, -1, 0, -1, 0, -1 };
  int PieceWhole[6] = { 0, -1, 0, -1, 0, -1 };
  /// Inputs resampled to an image (vtkNeuralCompressResample.h): 1 for the source samples outside the domain (never
  /// trained on); the decoded output is NaN at the decoded points nearest to them. Null for image inputs.
  std::shared_ptr<const std::vector<uint8_t>> Outside;
  std::shared_ptr<const SourceSamples> Samples; ///< resampled inputs only
  /// Sparse inputs (vtkNeuralCompressSparse.h): the macrocells whose field may differ from Background (the others
  /// are Background exactly; nv::SourceInfo::occupancy). Null otherwise.
  std::shared_ptr<const std::vector<uint32_t>> Occupancy;
  double Background = 0.0;
  /// Seconds from the execution that asked for this field until it was ready (resampling, reading, probing,
  /// hashing): TimeBudget counts them.
  double PreparationSeconds = 0.0;
  /// A resampling coarsened to fit the TimeBudget: the dimensions the output keeps at OutputResolution 0 0 0 (0: none).
  int CoarsenedDims[3] = { 0, 0, 0 };
  /// Out-of-core inputs (vtkNeuralOutOfCoreInput.h): the file the network trains from and is measured against (no
  /// field in memory); null otherwise.
  std::shared_ptr<const OutOfCoreFile> OutOfCore;
};

/// The output geometry of `field` at `outputResolution` (vtkNeuralCompress::OutputResolution): a change re-decodes the
/// network, it never retrains it.
OutputGeometry OutputGeometryOf(
  const FieldInfo& field, const int outputResolution[3], int finestResolution, int baseResolution);
/// True when two geometries decode the same samples.
bool SameDecodedGrid(const OutputGeometry& a, const OutputGeometry& b);

/// True when float32 holds values in [lo, hi] to well within a network's accuracy (no overflow, no underflow, its
/// rounding at that magnitude below 1e-4 of the range); else "Decoded, float32" gives float64.
bool Float32Holds(double lo, double hi);


/// Training of one time step: created by the filter, trained by its run, finalised in the run's thread.
class Job
{
public:
  Job() = default;
  /// The run (its thread may be finalising into this job) ends before any member goes.
  ~Job()
  {
    this->Retiring = true; // a decode at a phase end stops at its next chunk
    if (this->LiveWriter.joinable())
      this->LiveWriter.join();
    this->Run.reset();
  }
  Job(const Job&) = delete;
  Job& operator=(const Job&) = delete;

  uint64_t Key = 0;
  double Time = 0.0;
  FieldInfo Field;
  Settings TrainingSettings; ///< the filter's settings this job trains with: the one source of its engine configs
  /// The layout of the job's network. SizeForPSNR: written by the run's prologue (SearchSizeForPsnr) under Mutex,
  /// so the filter's thread reads it with Layout() while the run is Starting.
  nv::ModelConfig NetworkConfig;
  /// NetworkConfig, read under Mutex.
  nv::ModelConfig Layout() const
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    return this->NetworkConfig;
  }
  nv::SessionOptions SessionOptions; ///< the options of the job's session (the size search's sessions too)
  /// SizedForPsnr: the largest table size the search may try (EngineConfigs::SearchMaxLog2); 0: no search.
  int SearchMaxLog2 = 0;
  /// SizeForPSNR (SearchMaxLog2 > 0): the smallest table whose stored network reaches the target PSNR, searched by
  /// training candidates (nv::searchSizeForPsnr) in the run's prologue, before InstallInitialNetwork; sets
  /// NetworkConfig's table size and SizeNote. Throws nv::Error (the run fails) when aborted or out of memory.
  void SearchSizeForPsnr(const std::function<bool()>& abort);
  nv::SourceInfo Source;          ///< what the network represents (geometry, value range, raw bytes)
  nv::TrainConfig Train; ///< the optimiser settings of this job (a later Continue trains with them)
  nv::Precision Storage = nv::Precision::Float16;
  std::string DeviceNote;
  /// How the automatic size was fitted to an out-of-core input's MemoryBudget, or searched for SizeForPSNR ("" if not).
  std::string SizeNote;
  std::atomic<bool> WarmStart{ false }; ///< set where the initial network is installed (the run's prologue)
  std::shared_ptr<nv::NetworkSession> Session;
  std::shared_ptr<TrainingData> Data;
  std::unique_ptr<TrainingRun> Run; ///< null for a constant field (represented exactly)
  uint64_t EmittedSerial = ~uint64_t(0);
  /// Set by the filter before it stops a run it replaces (another time step or input): the phase end keeps the
  /// network for warm starts but skips the decode and the measurement, so the GUI thread waits one chunk only.
  std::atomic<bool> Retiring{ false };
  int OutputMode = 0; ///< read by the run's thread at phase ends (set under Mutex)
  /// The decode at a phase end polls DecodeAbort (besides Retiring) and tells DecodeProgress its fraction done; set
  /// by the filter before the run starts (a run in the calling thread: the filter's abort flag and progress).
  std::function<bool()> DecodeAbort;
  std::function<void(double)> DecodeProgress;
  /// Why the decode at the last phase end gave no field (memory, abort; the network is kept); the filter reports it
  /// once. Under Mutex.
  std::string DecodeError;

  /// The network and numbers of the last ended phase (null before).
  std::shared_ptr<const NetworkRecord> Final() const;
  vtkSmartPointer<vtkDataArray> FinalDecoded(int outputMode) const;
  /// Keeps the decoded field of the final network (decoded on demand for a restored or cached one) so that
  /// re-executions in the same output mode do not decode it again.
  void KeepDecoded(vtkSmartPointer<vtkDataArray> decoded, int outputMode);
  /// A new output geometry (OutputResolution changed): the decoded field is dropped (decoded again on demand), the
  /// network kept. False when the geometry is the same.
  bool SetOutputGeometry(const OutputGeometry& geometry);
  /// Runs in the training thread at the end of a phase: the stored-precision network becomes the session's, it is
  /// measured over every source sample, serialized and (for decoded output modes) decoded.
  void Finalize(const RunStatus& status);
  /// A network that needs no training (cached, restored from a state file).
  void SetFinal(std::shared_ptr<const NetworkRecord> record);
  /// For a field with no training (constant): finalise at once.
  void FinalizeWithoutTraining();
  /// The job's initial network becomes the session's: WarmSeed's parameters when its layout is this job's, else a
  /// seeded random initialisation. Runs in the training run's thread (its prologue), or in the caller's for a job
  /// without training; may throw (the run fails).
  void InstallInitialNetwork();
  /// A network to warm-start from (null: none). InstallInitialNetwork releases it.
  NetworkBytes WarmSeed;
  /// True until InstallInitialNetwork ran.
  bool InitialNetworkPending() const { return !this->InitialInstalled.load(); }
  /// The record of the network the session holds now (a snapshot while training; its bytes at most 1 s old, null
  /// until the first ones are written: they are serialized off the caller's thread once the run has installed its
  /// initial network).
  NetworkRecord Snapshot();
  /// True when live bytes were written after the last snapshot read them (an update would carry them).
  bool LiveBytesPending() const;
  /// Waits at most `seconds` for the first live bytes (a small network has them within milliseconds, so the
  /// execution that started the job outputs it); true when they exist.
  bool WaitForFirstLiveBytes(double seconds);
  bool FirstBytesAwaited = false; ///< the filter waited for them once (its thread only)
  /// Out-of-core inputs: the exact figures of the network shown while the run is paused (MeasureNow), streamed over
  /// the file in the filter's thread; live snapshots at that step carry them instead of the estimate. False when the
  /// pass was aborted or failed (`problem`).
  bool MeasurePaused(const std::function<bool()>& abort, const std::function<void(double)>& progress,
    std::string& problem);

  mutable std::mutex Mutex;

private:
  /// What the phase end measured of the network: over every source sample, and at a resampled input's own samples.
  struct PhaseMeasurement
  {
    nv::ErrorStats Error;
    double ResampledPsnr = std::numeric_limits<double>::quiet_NaN();
    int64_t SourceSamples = 0;
    bool Exact = true; ///< false: an out-of-core pass that was aborted (Error holds the last estimate)
  };
  /// The phase end's measurement of an out-of-core input: one streamed pass over the file (abortable like the
  /// decode); its last estimate when aborted.
  PhaseMeasurement MeasureOutOfCoreFile(const FieldInfo& field, const RunStatus& status, bool abortedBefore);
  /// Finalize of a job being replaced: the stored-precision `model` kept for warm starts and the cache, state
  /// "Interrupted", without a decode or a measurement.
  void KeepInterruptedNetwork(nv::Model& model, const RunStatus& status);
  /// The error-bounded mode (TrainingSettings.MaxError > 0): the corrections of the stored `model`, which the
  /// session holds; computed slab by slab on the training field. Returns why it was not kept (empty: kept or off).
  std::string CorrectErrors(nv::Model& model);
  /// The output field decoded at a phase end (decoded modes; null for the others, or after an abort or a failure,
  /// whose message goes to `decodeError`).
  vtkSmartPointer<vtkDataArray> DecodeAtPhaseEnd(
    const FieldInfo& field, int mode, bool abortedBefore, std::string& decodeError);
  /// The record of the network at a phase end: `model` with its statistics, serialized, and the user's figures.
  std::shared_ptr<NetworkRecord> MeasuredRecord(
    nv::Model& model, const RunStatus& status, const PhaseMeasurement& measured, bool abortedBefore);
  /// Starts LiveWriter when a snapshot's bytes are due (none yet, or older than a second) and none is being written.
  void StartLiveWriterIfDue(const RunStatus& status);
  /// Serializes the session's network of the moment into LiveBytes (in LiveWriter's thread, or the caller's).
  void WriteLiveBytes(const RunStatus& status);

  NetworkBytes LiveBytes; ///< under Mutex, as the five below
  uint64_t LiveBytesSerial = 0;        ///< incremented by every write
  uint64_t LiveBytesSerialEmitted = 0; ///< the serial the last snapshot read
  std::chrono::steady_clock::time_point LiveBytesTime;
  int64_t LiveModelBytes = 0;
  bool LiveWriting = false;  ///< LiveWriter runs (under Mutex)
  std::thread LiveWriter;    ///< serializes a live snapshot off the filter's thread
  std::shared_ptr<const NetworkRecord> FinalRecord;
  std::atomic<bool> InitialInstalled{ false };
  vtkSmartPointer<vtkDataArray> Decoded;
  int DecodedMode = 0;
  nv::ErrorStats PausedFigures; ///< MeasurePaused's (under Mutex)
  int64_t PausedFiguresStep = -1; ///< the step they were measured at (-1: none)
};

/// 64-bit key of a training: the field's values, geometry and the settings.
uint64_t TrainingKey(const nv::VolumeView& view, const FieldInfo& field, const Settings& s);

} // namespace vtkNeuralCompressInternals

#endif
