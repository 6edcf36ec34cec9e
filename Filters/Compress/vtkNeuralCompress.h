/**
 * @class   vtkNeuralCompress
 * @brief   trains a neural representation (multiresolution hash grid + MLP) of a scalar field
 *
 * vtkNeuralCompress takes a dataset and one of its point or cell arrays (any numeric type;
 * vectors are reduced to their magnitude or to one component) and trains a neural network that
 * represents the field. Images train directly; rectilinear, structured and unstructured grids,
 * planar poly data, composite datasets (one network over the union of the blocks) and AMR
 * (the finest level wins) are first resampled onto an image covering their bounds
 * (SamplingDimensions; VTK's vtkResampleToImage), whose points outside the domain are never
 * trained on and decode to NaN. The work is done by the VTK-free NeuralVolume engine;
 * this class only translates VTK data and properties into engine calls.
 *
 * Output port 0: vtkImageData with the input's bounds (spacing adapted when OutputResolution
 * is set). Its field data carries the serialized network (`NeuralNetwork`, vtkUnsignedCharArray, and
 * `NeuralNetworkSession`, the key of the trained session for renderers of the same process; see
 * vtkNeuralNetworkArray) and the metadata arrays `NeuralTrainingSeconds`, `NeuralSteps`,
 * `NeuralPSNR`, `NeuralMaxError`, `NeuralCompressionRatio`, `NeuralModelBytes`,
 * `NeuralInvalidSamples`, `NeuralGpuMemoryBytes`, `NeuralDevice`, `NeuralCudaDevice` (the GPU ordinal, -1 on
 * the CPU), `NeuralTrainingState`,
 * `NeuralWarmStart`, `NeuralRestored`, `NeuralTime` and `NeuralValueRange`. OutputMode decides
 * whether it also holds the decoded field (under the input array's name, point data for a point
 * array, cell data for a cell array), in the input's type or in float32.
 *
 * Output port 1: vtkTable training log with the columns Step, Loss, LearningRate,
 * ElapsedSeconds and PSNR (NaN except every PSNRInterval steps and at the last step; the
 * intermediate values are estimated on a fixed random subset of voxels, the last one is over
 * every input voxel).
 *
 * Training stops after TrainingSteps steps, TimeBudget seconds or at TargetPSNR, whichever comes
 * first, or when the algorithm's AbortExecute flag is set (cleared again by the next execution).
 *
 * With TrainInBackground (the default), RequestData returns at once: training runs in a thread of
 * its own, the output carries the network of the moment (the Neural Volume of this process renders
 * the live network), GetNeedsUpdate() tells ParaView's live-source poller when a newer state exists,
 * and the controls (PauseTraining, ResumeTraining, ContinueTraining, FastForward, StopTraining,
 * DecodeNow, WaitForTraining) act on the run. A network is trained once per input content and
 * settings: re-executions, time steps seen before (cached up to NetworkCacheMiB) and networks
 * restored from a state file (TrainedNetworks) are reused without a training step. Time step t+1
 * warm-starts from the network of the nearest time step trained before.
 *
 * Output port 2: vtkTable of metrics, one row per time step trained or restored.
 *
 * Only vtkImageData input is supported in this version; other dataset types produce an error.
 * Inputs that cannot be trained (no array, all values NaN/Inf, empty extent, a configuration
 * the engine rejects) produce an error, an output 0 without arrays (an image input keeps its
 * geometry so the pipeline does not execute again) and an empty log. NaN/Inf values are left
 * out of training with a warning; a constant field is represented exactly without training.
 */
#ifndef vtkNeuralCompress_h
#define vtkNeuralCompress_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkDataObjectAlgorithm.h"
#include "vtkSmartPointer.h" // for vtkSmartPointer

#include <cstdint> // for uint64_t
#include <memory>  // for std::shared_ptr
#include <string>  // for std::string

class vtkDataArray;
class vtkDataSet;
class vtkImageData;
class vtkMultiProcessController;
class vtkTable;
namespace nv
{
struct RunLimits;
struct RunStatus;
struct TrainingData;
class TrainingRun;
}
namespace vtkNeuralCompressInternals
{
class Job;
struct FieldInfo;
struct OutputGeometry;
struct NetworkRecord;
struct SelectedInput;
struct InputRequest;
struct InputIdentity;
struct PreparedField;
struct Settings;
struct SparseVoxels;
struct PieceSums;
}

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralCompress : public vtkDataObjectAlgorithm
{
public:
  static vtkNeuralCompress* New();
  vtkTypeMacro(vtkNeuralCompress, vtkDataObjectAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum VectorModes
  {
    MAGNITUDE = 0,
    COMPONENT = 1
  };
  enum LossTypes
  {
    LOSS_L1 = 0,
    LOSS_L2 = 1
  };
  enum Schedules
  {
    STEP_DECAY = 0,
    CONSTANT = 1,
    ANNEALED = 2 ///< the default: 500 steps at the full rate, then a cosine to 1/100 (nv::LearningRateSchedule::Auto)
  };
  enum Precisions
  {
    FLOAT32 = 0,
    FLOAT16 = 1,
    QUANTIZED8 = 2, ///< hash table as 8-bit codes, entropy coded; MLP fp16 (nv::Precision::Quantized8)
    /// The default: with an automatic table size, 8-bit codes where the target ratio is reachable (a table twice as
    /// large in the same bytes), Float16 for a small input sized for quality; Float16 with a table size set.
    AUTOMATIC_PRECISION = 3
  };
  enum Devices
  {
    DEVICE_AUTO = 0,
    DEVICE_CPU = 1,
    DEVICE_CUDA = 2
  };
  enum Strategies
  {
    STRATEGY_AUTO = 0,
    STRATEGY_GPU_RESIDENT = 1,
    STRATEGY_HOST_SAMPLED = 2
  };

  ///@{
  /// How a multi-component array becomes a scalar field: its magnitude or one component.
  vtkSetClampMacro(VectorMode, int, MAGNITUDE, COMPONENT);
  vtkGetMacro(VectorMode, int);
  vtkSetClampMacro(VectorComponent, int, 0, 255);
  vtkGetMacro(VectorComponent, int);
  ///@}

  ///@{
  /// Training length: stops at TrainingSteps or after TimeBudget seconds (0 = no time limit).
  /// A negative count is refused: TrainingSteps becomes 0 (no training) with a warning.
  void SetTrainingSteps(int steps);
  vtkGetMacro(TrainingSteps, int);
  vtkSetClampMacro(TimeBudget, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(TimeBudget, double);
  ///@}

  ///@{
  /// Optimiser settings.
  vtkSetClampMacro(BatchSize, int, 1, VTK_INT_MAX);
  vtkGetMacro(BatchSize, int);
  vtkSetClampMacro(LearningRate, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(LearningRate, double);
  vtkSetClampMacro(Seed, int, 0, VTK_INT_MAX);
  vtkGetMacro(Seed, int);
  vtkSetClampMacro(Loss, int, LOSS_L1, LOSS_L2);
  vtkGetMacro(Loss, int);
  vtkSetClampMacro(LearningRateSchedule, int, STEP_DECAY, ANNEALED);
  vtkGetMacro(LearningRateSchedule, int);
  ///@}

  ///@{
  /// Target raw/model size ratio; used to pick the hash table size when Log2TableSize is 0.
  /// 0 = automatic: the largest table that gives 10:1, else (a small input) the quality-first size
  /// (nv::qualityFirstLog2TableSize, no warning). An explicit target out of reach: the smallest table and a warning.
  vtkSetClampMacro(TargetCompressionRatio, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(TargetCompressionRatio, double);
  ///@}

  ///@{
  /// Sizing for a quality instead of a ratio (Log2TableSize Automatic only; 0 = off): the smallest hash table (in the
  /// storage StoragePrecision gives: Automatic is 8-bit) whose stored network reaches this PSNR (dB) in TrainingSteps
  /// steps, found by training candidates before the job's own training (nv::searchSizeForPsnr; TargetCompressionRatio
  /// is then ignored). Not to be confused with TargetPSNR, which stops a training. The summary says which sizes were
  /// trained and whether the final network reached the target. Dense image inputs only.
  vtkSetClampMacro(SizeForPSNR, double, 0.0, 1000.0);
  vtkGetMacro(SizeForPSNR, double);
  ///@}

  ///@{
  /// Error-bounded mode: after training, the samples whose decoded value misses the input by more than MaxError
  /// (data units) are stored with the network as a sparse correction list, so that the field decoded on the input's
  /// grid meets |decoded - input| <= MaxError at every sample; the ratio counts the list. 0 = off. A negative or
  /// non-finite value is refused (a warning; the mode is off). Image inputs trained on their own samples only.
  void SetMaxError(double bound);
  vtkGetMacro(MaxError, double);
  ///@}

  ///@{
  /// Hash-grid encoding. Log2TableSize 0 derives the table size from TargetCompressionRatio;
  /// FinestResolution 0 means twice the largest input dimension.
  vtkSetMacro(Levels, int);
  vtkGetMacro(Levels, int);
  vtkSetMacro(FeaturesPerLevel, int);
  vtkGetMacro(FeaturesPerLevel, int);
  vtkSetMacro(Log2TableSize, int);
  vtkGetMacro(Log2TableSize, int);
  vtkSetMacro(BaseResolution, int);
  vtkGetMacro(BaseResolution, int);
  vtkSetMacro(FinestResolution, int);
  vtkGetMacro(FinestResolution, int);
  ///@}

  ///@{
  /// The MLP: width (16/32/64/128) and number of hidden layers (1-8).
  vtkSetMacro(NetworkWidth, int);
  vtkGetMacro(NetworkWidth, int);
  vtkSetMacro(HiddenLayers, int);
  vtkGetMacro(HiddenLayers, int);
  ///@}

  ///@{
  /// Precision of the stored parameters (FLOAT32, FLOAT16, QUANTIZED8 or AUTOMATIC_PRECISION).
  vtkSetClampMacro(StoragePrecision, int, FLOAT32, AUTOMATIC_PRECISION);
  vtkGetMacro(StoragePrecision, int);
  ///@}

  ///@{
  /// Compute device (DEVICE_AUTO picks CUDA when a GPU is usable, else the CPU with a message;
  /// DEVICE_CUDA without a usable GPU is an error) and number of CPU threads (0 = all cores).
  vtkSetClampMacro(Device, int, DEVICE_AUTO, DEVICE_CUDA);
  vtkGetMacro(Device, int);
  vtkSetClampMacro(Threads, int, 0, 4096);
  vtkGetMacro(Threads, int);
  ///@}

  ///@{
  /// GPU training strategy: GPU-resident (volume uploaded once, targets sampled on the GPU),
  /// host-sampled (CPU threads sample the next batch while the GPU trains), or Auto (resident
  /// when the volume fits in GPU memory). Ignored on the CPU.
  vtkSetClampMacro(TrainingStrategy, int, STRATEGY_AUTO, STRATEGY_HOST_SAMPLED);
  vtkGetMacro(TrainingStrategy, int);
  ///@}

  ///@{
  /// Samples per axis of the decoded output (0 0 0 = the input's point dimensions for a point
  /// array, its cell dimensions for a cell array).
  vtkSetVector3Macro(OutputResolution, int);
  vtkGetVector3Macro(OutputResolution, int);
  ///@}

  ///@{
  /// Inputs that are not images: samples per axis of the image they are resampled onto before
  /// training (0 0 0 = automatic: about 27 per source point or cell, for AMR the finest level's
  /// spacing, between 32^3 and 256^3 in all). Ignored for image inputs.
  vtkSetVector3Macro(SamplingDimensions, int);
  vtkGetVector3Macro(SamplingDimensions, int);
  ///@}

  enum SamplingModes
  {
    SAMPLING_RESAMPLE = 0, ///< training targets interpolated in the resampled image
    SAMPLING_PROBE = 1     ///< training targets probed inside the source cells at random points (a bank, once)
  };
  ///@{
  /// Inputs that are not images: where the training targets come from. Resample (default): trilinear
  /// interpolation of the image the input is resampled onto (fast; its resolution bounds the accuracy at the
  /// source). Probe: a bank of ProbePoints random points of the input's bounds, each probed inside the source's
  /// cells by VTK (vtkProbeFilter with a vtkStaticCellLocator) once per input; each training step draws its batch
  /// from the bank. Ignored for image inputs.
  vtkSetClampMacro(Sampling, int, SAMPLING_RESAMPLE, SAMPLING_PROBE);
  vtkGetMacro(Sampling, int);
  /// Probe sampling: random points probed for the bank (0 = automatic: 2^20); points outside the domain are
  /// dropped. At most 2^26.
  vtkSetClampMacro(ProbePoints, int, 0, 1 << 26);
  vtkGetMacro(ProbePoints, int);
  ///@}

  enum ParticleFieldModes
  {
    PARTICLES_INTERPOLATE = 0, ///< sum_i f_i W_i / sum_i W_i (normalised, SPH/Shepard style)
    PARTICLES_DENSITY = 1      ///< sum_i f_i W_i (f_i a mass: its density)
  };
  enum ParticleKernels
  {
    KERNEL_GAUSSIAN = 0,
    KERNEL_CUBIC_SPLINE = 1,
    KERNEL_WENDLAND_C2 = 2
  };
  ///@{
  /// Particle inputs (poly data of vertices or points only, unstructured grids of vertex cells): the field the
  /// particles define (Cuda/Particles/ParticleField.h), the smoothing kernel, the support radius of every particle
  /// (0 = automatic: twice the mean particle spacing) or the point array of per-particle radii (empty: the
  /// constant). Outside every particle's support the field is empty. Ignored for other inputs.
  vtkSetClampMacro(ParticleField, int, PARTICLES_INTERPOLATE, PARTICLES_DENSITY);
  vtkGetMacro(ParticleField, int);
  vtkSetClampMacro(ParticleKernel, int, KERNEL_GAUSSIAN, KERNEL_WENDLAND_C2);
  vtkGetMacro(ParticleKernel, int);
  vtkSetMacro(ParticleRadius, double);
  vtkGetMacro(ParticleRadius, double);
  vtkSetStdStringFromCharMacro(ParticleRadiusArray);
  vtkGetCharFromStdStringMacro(ParticleRadiusArray);
  ///@}

  ///@{
  /// Out-of-core inputs (the Neural Out-of-Core Reader's output): host memory in MiB that the file's samples may take
  /// (the random block buffer, the PSNR probe and a streamed pass's slabs); 0 = automatic (a quarter of what the
  /// process may allocate, at most three times the file). Ignored for other inputs.
  vtkSetClampMacro(MemoryBudget, double, 0.0, 1.0e9);
  vtkGetMacro(MemoryBudget, double);
  ///@}

  ///@{
  /// Out-of-core inputs: the block buffer's readers bypass the page cache (O_DIRECT, whole 4 KiB pages; where the
  /// file system refuses it, each read's pages are dropped after it), as on a machine whose memory cannot hold the
  /// file. Off (default): reads go through the page cache. The values read are the same either way (not part of the
  /// training key).
  vtkSetClampMacro(BypassPageCache, int, 0, 1);
  vtkGetMacro(BypassPageCache, int);
  ///@}

  ///@{
  /// Steps between two PSNR estimates in the training log (0 = only at the end).
  vtkSetClampMacro(PSNRInterval, int, 0, VTK_INT_MAX);
  vtkGetMacro(PSNRInterval, int);
  ///@}

  ///@{
  /// Stop when the PSNR estimate reaches this many dB (0 = off; estimates every PSNRInterval steps,
  /// every 100 when PSNRInterval is 0).
  vtkSetClampMacro(TargetPSNR, double, 0.0, 1000.0);
  vtkGetMacro(TargetPSNR, double);
  ///@}

  enum OutputModes
  {
    OUTPUT_NETWORK_ONLY = 0,
    OUTPUT_INPUT_TYPE = 1,
    OUTPUT_FLOAT32 = 2
  };
  ///@{
  /// What output 0 holds besides the network: nothing (the Neural Volume decodes on demand; the
  /// default, the output is smaller than the input), the decoded field in the input's type, or in
  /// float32. Changing it never retrains.
  vtkSetClampMacro(OutputMode, int, OUTPUT_NETWORK_ONLY, OUTPUT_FLOAT32);
  vtkGetMacro(OutputMode, int);
  ///@}

  ///@{
  /// Train in a background thread (RequestData returns at once; see the class comment) or in
  /// RequestData (blocking).
  vtkSetMacro(TrainInBackground, bool);
  vtkGetMacro(TrainInBackground, bool);
  vtkBooleanMacro(TrainInBackground, bool);
  ///@}

  ///@{
  /// Bit-for-bit repeatable training on the same machine: TrainingSteps steps exactly (TimeBudget and
  /// TargetPSNR are ignored), the seed, and deterministic reductions (the CPU engine's fixed order for
  /// a thread count; on CUDA, gradients summed in 64-bit fixed point, slower than the float atomics).
  vtkSetMacro(Deterministic, bool);
  vtkGetMacro(Deterministic, bool);
  vtkBooleanMacro(Deterministic, bool);
  ///@}

  ///@{
  /// At the end of training, the network of the best PSNR estimate replaces the last one when it was better by more
  /// than 0.1 dB (training that collapsed late; needs PSNRInterval > 0). Default on.
  vtkSetMacro(KeepBestNetwork, bool);
  vtkGetMacro(KeepBestNetwork, bool);
  vtkBooleanMacro(KeepBestNetwork, bool);
  ///@}

  ///@{
  /// Start training a time step from the network of the nearest time step trained before.
  vtkSetMacro(WarmStart, bool);
  vtkGetMacro(WarmStart, bool);
  vtkBooleanMacro(WarmStart, bool);
  ///@}

  ///@{
  /// Host memory for networks of other time steps (MiB); least recently used ones go first.
  vtkSetClampMacro(NetworkCacheMiB, int, 0, 1 << 20);
  vtkGetMacro(NetworkCacheMiB, int);
  ///@}

  ///@{
  /// Steps added by ContinueTraining().
  vtkSetClampMacro(ContinueSteps, int, 1, VTK_INT_MAX);
  vtkGetMacro(ContinueSteps, int);
  ///@}

  ///@{
  /// Controls of the current training run (Properties panel buttons; from Python e.g.
  /// `nc.PauseTraining()`). They take effect at once; none stays set for the next run.
  void PauseTraining();
  void ResumeTraining();
  void ContinueTraining(); ///< ContinueSteps more steps
  void FastForward();      ///< 1000 more steps without intermediate views
  void StopTraining();
  void DecodeNow();        ///< decode the current network into the output now (decoded output modes)
  /// Out-of-core inputs, while paused: the next update measures the network shown over every voxel of the file (one
  /// streamed pass, with progress, abortable); its figures replace the estimate until training resumes.
  void MeasureNow();
  /// Block until the current run has finished its phase (at most `seconds`, < 0: no limit); the
  /// next update then shows the final network.
  void WaitForTraining(double seconds);
  void WaitForTraining() { this->WaitForTraining(-1.0); }
  ///@}

  /// For ParaView's live-source poller: true (and the algorithm Modified()) when the run has a newer
  /// state than the last output. Under MPI (called on rank 0, as ParaView's poller does) every rank answers for its
  /// own run and every rank is Modified() when one needs it, so the update that follows executes on every rank.
  bool GetNeedsUpdate();

  /// State of the current run for the panel: "Training 1234/2000 steps, 12.3 s, PSNR 41.2 dB".
  const char* GetTrainingStatus();
  /// Training steps this filter object ran in total (tests check that a restore trains none).
  vtkIdType GetTotalStepsTrained();
  /// 1 when this process has a GPU the engine can use (the panel hides the GPU-only settings otherwise).
  int GetGpuUsable();

  ///@{
  /// Networks saved with a state file: "nvnet1" followed by one "key:base64" entry per time step.
  /// Set by a loaded state (each network is used only when its key, computed from the input's
  /// values and the settings, matches); Get returns the networks this filter holds now.
  void SetTrainedNetworks(const char* value);
  const char* GetTrainedNetworks();
  ///@}

protected:
  vtkNeuralCompress();
  ~vtkNeuralCompress() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestDataObject(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  /// RequestInformation of an input that is not an image (in one process): the extent of the image it is resampled
  /// onto, or a sparse grid's index box; the input brought up to date first when it is empty.
  void AnnounceResampledExtent(vtkInformation* inInfo, vtkInformation* outInfo, vtkDataObject* input);
  /// RequestInformation under MPI, a dataset or composite that is not an image: whether every rank trains its own
  /// piece (a collective when the upstream pipeline, array or SamplingDimensions changed) and the lattice's extent;
  /// false: gathered instead.
  bool AnnounceGridPieces(vtkInformation* inInfo, vtkInformation* outInfo, vtkDataObject* input);
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  int VectorMode = MAGNITUDE;
  int VectorComponent = 0;
  int TrainingSteps = 2000;
  double TimeBudget = 60.0;
  int BatchSize = 65536;
  double LearningRate = 0.01;
  int Seed = 1;
  int Loss = LOSS_L1;
  int LearningRateSchedule = ANNEALED;
  double TargetCompressionRatio = 0.0;
  double SizeForPSNR = 0.0;
  double MaxError = 0.0;
  int Levels = 16;
  int FeaturesPerLevel = 4;
  int Log2TableSize = 0;
  int BaseResolution = 16;
  int FinestResolution = 0;
  int NetworkWidth = 64;
  int HiddenLayers = 4;
  int StoragePrecision = AUTOMATIC_PRECISION;
  int Device = DEVICE_AUTO;
  int Threads = 0;
  int TrainingStrategy = STRATEGY_AUTO;
  int OutputResolution[3] = { 0, 0, 0 };
  int SamplingDimensions[3] = { 0, 0, 0 };
  int Sampling = SAMPLING_RESAMPLE;
  int ProbePoints = 0;
  double MemoryBudget = 0.0;
  int BypassPageCache = 0;
  int ParticleField = PARTICLES_INTERPOLATE;
  int ParticleKernel = KERNEL_CUBIC_SPLINE;
  double ParticleRadius = 0.0;
  std::string ParticleRadiusArray;
  int PSNRInterval = 100;
  double TargetPSNR = 0.0;
  int OutputMode = OUTPUT_NETWORK_ONLY;
  bool TrainInBackground = true;
  bool Deterministic = false;
  bool KeepBestNetwork = true;
  int NetworkCacheMiB = 256;
  bool WarmStart = true;
  int ContinueSteps = 1000;

private:
  vtkNeuralCompress(const vtkNeuralCompress&) = delete;
  void operator=(const vtkNeuralCompress&) = delete;

  /// The input's field, a job training it when the input or the settings changed, the outputs; false after
  /// reporting an error. `background`: the field is prepared in a thread of its own (Apply returns at once). Its
  /// steps (vtkNeuralCompressExecute.cxx) follow.
  bool Execute(vtkDataObject* inputObject, vtkInformationVector** inputVector,
    vtkImageData* output, vtkTable* log, vtkTable* metrics, double time, bool background);
  /// RequestData under MPI with an image input (vtkNeuralCompressPartition.h): this rank's network of its own piece
  /// (trained here or, with TrainInBackground, in the background; no communication while training), the output
  /// cropped to the piece, then the global figures (one all-reduce that every rank reaches).
  /// vtkNeuralCompressPiece.cxx.
  void ExecutePiece(vtkImageData* local, vtkInformation* inInfo, vtkImageData* output, vtkTable* log,
    vtkTable* metrics, double time);
  /// RequestData under MPI with a dataset or composite (vtkNeuralCompressDataSetPiece.h): as ExecutePiece, on this
  /// rank's piece resampled on its region of the whole lattice.
  void ExecuteGridPiece(vtkDataObject* local, vtkInformation* inInfo, vtkImageData* output, vtkTable* log,
    vtkTable* metrics, double time);
  /// Trains Internals->Piece (when `hasPiece`), then the global figures (every rank); `sourceBytes` >= 0: the bytes
  /// the rank's share of the compression ratio counts.
  void TrainPiece(bool hasPiece, int ranksHere, double sourceBytes, vtkInformation* inInfo, vtkImageData* output,
    vtkTable* log, vtkTable* metrics, double time);
  /// ExecutePiece: this rank's error sums of the current network (measured once per final network; zero: none).
  vtkNeuralCompressInternals::PieceSums MeasureCurrentPiece();
  /// ExecutePiece while this rank's run trains in the background: its sums from the output's live PSNR estimate.
  vtkNeuralCompressInternals::PieceSums EstimateCurrentPiece(vtkImageData* output);
  /// True while the current run trains (not settled).
  bool TrainingLive();
  /// GetNeedsUpdate's decision for this process's run alone (the live-source bookkeeping updated, not Modified()).
  bool LocalNeedsUpdate();
  /// Under MPI (a collective): whether any rank's run needs an update; every rank is Modified() when one does.
  bool NeedsUpdateOnEveryRank(vtkMultiProcessController* controller, bool local);
  /// The RMI by which rank 0's GetNeedsUpdate asks the other ranks (vtkNeuralCompressPiece.cxx).
  static void LiveUpdateRmi(void* localArg, void* remoteArg, int remoteArgLength, int remoteProcessId);
  /// This filter in the process-wide list the RMI finds it in (the same number on every rank: ParaView creates a
  /// pipeline's objects in the same order on every rank).
  void RegisterForLiveUpdates();
  void UnregisterForLiveUpdates();
  /// ExecutePiece (a collective): every rank's networks to rank 0, which adds them to GetTrainedNetworks (a state
  /// saved from the client then holds every rank's network; on loading, each rank finds its own by its key).
  void GatherPeerNetworks();
  /// What this execution reads from the pipeline (the input, its selected array or the name of the one to
  /// resample); false after reporting an error.
  bool RequestInput(vtkDataObject* inputObject, vtkInformationVector** inputVector,
    vtkNeuralCompressInternals::InputRequest& request);
  vtkNeuralCompressInternals::InputIdentity IdentityOf(
    const vtkNeuralCompressInternals::InputRequest& request, const std::string& canonicalSettings, double time) const;
  /// The current job trains this input (unchanged since) with these settings at this time.
  bool IsCurrentTraining(const vtkNeuralCompressInternals::InputIdentity& identity) const;
  /// The training field of the request (resampled, read, probed, hashed); in the filter's thread or a
  /// preparation's (its messages then go through Report). False after reporting an error or when cancelled.
  bool PrepareField(const vtkNeuralCompressInternals::InputRequest& request,
    const vtkNeuralCompressInternals::Settings& settings, vtkNeuralCompressInternals::PreparedField& prepared);
  /// Background: outputs of the current job while a preparation runs, a job from a preparation that ended, or a
  /// new preparation for a new input, time or settings.
  bool ExecuteInBackground(const vtkNeuralCompressInternals::InputRequest& request,
    const vtkNeuralCompressInternals::Settings& settings, const vtkNeuralCompressInternals::InputIdentity& identity,
    vtkImageData* output, vtkTable* log, vtkTable* metrics);
  /// The ended preparation's messages printed and its field's job started; false after an error.
  bool AdoptPreparation();
  /// The previous network (or the promised geometry and no network) with the preparation's status line.
  bool EmitWhilePreparing(vtkImageData* output, vtkTable* log, vtkTable* metrics);
  /// An error (0), warning (1) or text (2) for the output window: printed here, or queued by a preparation's thread.
  void Report(int level, const std::string& text);
  /// A dataset that is not an image, resampled onto one (vtkNeuralCompressResample.h) with its outside points.
  bool ResampleInput(const vtkNeuralCompressInternals::InputRequest& request, double timeBudget,
    vtkNeuralCompressInternals::SelectedInput& input);
  /// Automatic sampling dimensions under a TimeBudget: `dims` lowered so that resampling takes at most a share of
  /// it (the cost per sample measured on the input), the output keeping the announced ones; false after an error.
  bool FitResamplingToBudget(const vtkNeuralCompressInternals::InputRequest& request, double timeBudget, int dims[3],
    vtkNeuralCompressInternals::SelectedInput& input);
  /// The engine's warnings posted since the last call (nv::takeWarnings: e.g. fewer threads than Threads asked).
  void ReportEngineWarnings();
  /// A warning when OutputResolution was finer than the network resolves (OutputGeometry::CapSamples).
  void ReportOutputCap(const vtkNeuralCompressInternals::OutputGeometry& geometry);
  /// The field's name, association and geometry; refuses an output the machine cannot hold, or no samples.
  bool DescribeField(
    const vtkNeuralCompressInternals::SelectedInput& input, vtkNeuralCompressInternals::FieldInfo& field);
  /// The training field (the array in place or a single-component copy, kept alive) and its statistics, checked.
  bool ReadField(const vtkNeuralCompressInternals::SelectedInput& input, vtkNeuralCompressInternals::FieldInfo& field,
    nv::TrainingData& data);
  /// Sampling "Probe": the bank of training points probed inside the source's cells; widens the value range.
  bool ProbeTrainingPoints(
    vtkDataObject* inputObject, vtkNeuralCompressInternals::FieldInfo& field, nv::TrainingData& data);
  /// Records the training key; a new job (StartJob) when it or the time differs from the current job's.
  void StartJobIfChanged(const vtkNeuralCompressInternals::InputIdentity& identity,
    const vtkNeuralCompressInternals::PreparedField& prepared);

  /// An out-of-core reader's output (vtkNeuralOutOfCoreInput.h): the file's header, value range (a streamed pass),
  /// block buffer and probe; false after reporting an error or when cancelled.
  bool PrepareOutOfCoreField(const vtkNeuralCompressInternals::InputRequest& request,
    const vtkNeuralCompressInternals::Settings& settings, vtkNeuralCompressInternals::PreparedField& prepared);
  /// MeasureNow's pass, in an execution (its progress and abort); false after reporting why it did not measure.
  bool MeasureRequestedNow(vtkNeuralCompressInternals::Job& job);

  /// The OpenVDB reader's sparse output (vtkNeuralCompressSparse.h): trained from its active voxels and background
  /// samples without a dense grid; false after reporting an error.
  bool ExecuteSparse(vtkDataObject* inputObject, vtkImageData* output, vtkTable* log, vtkTable* metrics, double time);
  /// The selected point array of the sparse output and its voxels; false after reporting an error.
  bool ReadSparseInput(
    vtkDataObject* inputObject, vtkNeuralCompressInternals::SparseVoxels& voxels, std::string& arrayName);
  /// The field of a sparse grid: its name and the geometry of its box (and of the decoded output).
  vtkNeuralCompressInternals::FieldInfo SparseFieldGeometry(
    const vtkNeuralCompressInternals::SparseVoxels& voxels, const std::string& arrayName);

  vtkNeuralCompressInternals::Settings CurrentSettings() const;
  /// A job for a new input or settings: a cached or restored network, or a training run.
  void StartJob(const vtkNeuralCompressInternals::FieldInfo& field,
    std::shared_ptr<nv::TrainingData> data,
    const vtkNeuralCompressInternals::Settings& settings, uint64_t key, double time);
  /// The training of a new job (no stored network): its warm-start seed (from the cache, or `cached`, this time
  /// step's network that another time step cut short), and its first phase -- or none for a constant field or no
  /// steps.
  void StartTraining(vtkNeuralCompressInternals::Job& job, const vtkNeuralCompressInternals::NetworkRecord* cached);
  /// The outputs from the current job (a snapshot while it trains). Its steps follow.
  bool EmitOutputs(vtkImageData* output, vtkTable* log, vtkTable* metrics);
  /// The run's status; prints its new warnings and notes; false (an error) when it failed.
  bool ReportRunStatus(vtkNeuralCompressInternals::Job& job, nv::RunStatus& status);
  /// The network to output (the run's snapshot while live, else the final one) and its decoded field, if any.
  bool CurrentNetwork(vtkNeuralCompressInternals::Job& job, bool live,
    vtkNeuralCompressInternals::NetworkRecord& record, vtkSmartPointer<vtkDataArray>& decoded);
  /// Decodes the session's network in this thread (progress, abort); null after reporting an error.
  vtkSmartPointer<vtkDataArray> DecodeNetwork(vtkNeuralCompressInternals::Job& job);
  void FillOutputs(vtkNeuralCompressInternals::Job& job, const vtkNeuralCompressInternals::NetworkRecord& record,
    vtkDataArray* decoded, bool live, vtkImageData* output, vtkTable* log, vtkTable* metrics);
  /// A network complete for the first time: its warnings (range, divergence, compression ratio) and the summary.
  void ReportFinalNetwork(
    vtkNeuralCompressInternals::Job& job, const vtkNeuralCompressInternals::NetworkRecord& record);
  /// Starts `job`'s run (in the background or here) with `limits`, `moreSteps` added to its first phase.
  void StartRun(vtkNeuralCompressInternals::Job& job, const nv::RunLimits& limits,
    int64_t moreSteps, bool fastForward);
  /// The current job's run, or null.
  nv::TrainingRun* CurrentRun();
  /// Continue / Fast-forward: more steps for the run, or a run from a cached or restored network.
  void ExtendTraining(int64_t steps, bool fastForward);

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
};

#endif
