// vtkNeuralCompress: a new job -- the model configuration, the session, warm start, a cached or restored network
// or a training run.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressState.h"

#include "Core/Error.h"
#include "Core/ResourceEstimate.h"
#include "Core/Serialization.h"

#include "vtkDataArray.h"

#include <algorithm>

//------------------------------------------------------------------------------
nvi::Settings vtkNeuralCompress::CurrentSettings() const
{
  nvi::Settings s;
  s.VectorMode = this->VectorMode;
  s.VectorComponent = this->VectorComponent;
  s.TrainingSteps = this->TrainingSteps;
  s.TimeBudget = this->TimeBudget;
  s.LearningRate = this->LearningRate;
  s.TargetCompressionRatio = this->TargetCompressionRatio;
  s.TargetPsnr = this->TargetPSNR;
  s.BatchSize = this->BatchSize;
  s.Seed = this->Seed;
  s.Loss = this->Loss;
  s.Schedule = this->LearningRateSchedule;
  s.Levels = this->Levels;
  s.Features = this->FeaturesPerLevel;
  s.Log2TableSize = this->Log2TableSize;
  s.BaseResolution = this->BaseResolution;
  s.FinestResolution = this->FinestResolution;
  s.Width = this->NetworkWidth;
  s.HiddenLayers = this->HiddenLayers;
  s.Precision = this->StoragePrecision;
  s.Device = this->Device;
  s.Threads = this->Threads;
  s.Strategy = this->TrainingStrategy;
  s.PsnrInterval = this->PSNRInterval;
  s.Deterministic = this->Deterministic;
  s.WarmStart = this->WarmStart;
  s.Sampling = this->Sampling;
  s.KeepBest = this->KeepBestNetwork;
  s.ProbePoints = this->ProbePoints;
  return s;
}

namespace
{
/// The network's layout from the settings and the trained field's size (an automatic table size from the target
/// ratio).
nv::ModelConfig NetworkConfigFor(const nvi::Settings& s, const int64_t* dims, int64_t rawBytes, nv::Precision storage)
{
  nv::ModelConfig config;
  config.encoding.levels = s.Levels;
  config.encoding.featuresPerLevel = s.Features;
  config.encoding.baseResolution = s.BaseResolution;
  config.encoding.perLevelScale = 0.0;
  // Default finest level: twice the largest dimension (never below the base resolution).
  config.encoding.finestResolution = s.FinestResolution > 0
    ? s.FinestResolution
    : static_cast<int>(std::max<int64_t>(2 * std::max({ dims[0], dims[1], dims[2] }), s.BaseResolution));
  config.network.width = s.Width;
  config.network.hiddenLayers = s.HiddenLayers;
  config.encoding.log2TableSize = s.Log2TableSize > 0 ? s.Log2TableSize : 10;
  nv::validate(config);
  if (s.Log2TableSize <= 0)
  {
    // Automatic (TargetCompressionRatio 0): the largest table that still gives 10:1, else the smallest one.
    const double target = s.TargetCompressionRatio > 0.0 ? s.TargetCompressionRatio : 10.0;
    config.encoding.log2TableSize = nv::chooseLog2TableSize(config, rawBytes, target, storage);
  }
  return config;
}

nv::TrainConfig TrainConfigFor(const nvi::Settings& s, bool lowPriority)
{
  nv::TrainConfig train;
  train.batchSize = s.BatchSize;
  train.seed = static_cast<uint64_t>(s.Seed);
  train.loss = s.Loss == vtkNeuralCompress::LOSS_L2 ? nv::LossType::L2 : nv::LossType::L1;
  train.optimizer.learningRate = s.LearningRate;
  // Annealed: TrainingRun sets the planned steps (the run's length) before each chunk of steps.
  train.optimizer.schedule = s.Schedule == vtkNeuralCompress::ANNEALED ? nv::LearningRateSchedule::Auto
                                                                        : nv::LearningRateSchedule::StepDecay;
  train.optimizer.stepDecay = s.Schedule == vtkNeuralCompress::STEP_DECAY;
  train.threads = s.Threads;
  train.strategy = static_cast<nv::TrainingStrategy>(s.Strategy);
  train.deterministic = s.Deterministic;
  train.lowPriority = lowPriority; // beside the GUI: its threads keep their share of the cores
  nv::validate(train);
  return train;
}

/// What the network represents: the trained field's geometry (points, or cell centres), value range, sparse
/// occupancy and resampled domain; checked as the network format checks it.
nv::SourceInfo SourceOf(const nvi::FieldInfo& field, const nvi::TrainingData& data)
{
  nv::SourceInfo src;
  const int64_t* dims = data.Field.View.dims;
  for (int d = 0; d < 3; ++d)
  {
    const double h = field.InputSpacing[d];
    const double first = field.InputOrigin[d] + field.InputExtent[2 * d] * h +
      (field.Cells && field.InputExtent[2 * d + 1] > field.InputExtent[2 * d] ? 0.5 * h : 0.0);
    src.dims[d] = dims[d];
    src.spacing[d] = h;
    src.origin[d] = first;
    src.bounds[2 * d] = first;
    src.bounds[2 * d + 1] = first + (dims[d] - 1) * h;
  }
  src.valueMin = field.Stats.min;
  src.valueMax = field.Stats.max;
  src.arrayName = field.Name;
  src.association = field.Cells ? 1 : 0;
  src.rawBytes = data.Field.RawBytes;
  if (field.Occupancy && int64_t(field.Occupancy->size()) == nv::occupancyWords(dims))
  {
    // A sparse source: its empty macrocells are the background exactly (renderers use it and skip them).
    src.occupancy = *field.Occupancy;
    src.background = field.Background;
  }
  if (field.Outside && int64_t(field.Outside->size()) == dims[0] * dims[1] * dims[2])
  {
    // A resampled input: the network keeps its domain, so renderers draw nothing outside it.
    src.domain.assign(size_t((field.Outside->size() + 31) / 32), 0u);
    for (size_t i = 0; i < field.Outside->size(); ++i)
      if (!(*field.Outside)[i])
        src.domain[i >> 5] |= 1u << (i & 31);
  }
  try
  {
    nv::validate(src);
  }
  catch (const nv::Error& e)
  {
    throw nv::Error(std::string("the input's geometry cannot be stored with a network: ") + e.what() + ". " +
      nvi::SpacingAdvice(field.InputSpacing, dims));
  }
  return src;
}

/// A network or a batch the machine cannot hold is refused before anything is allocated (throws nv::Error).
/// `fieldBytes`: the field uploaded to a GPU with the network (GPU-resident training), else 0.
void CheckTrainingMemory(
  const nv::ModelConfig& config, const nv::TrainConfig& train, nv::Device device, int64_t fieldBytes)
{
  const nv::MemoryEstimate estimate =
    nv::trainingMemory(config, train, device, device == nv::Device::Cuda ? fieldBytes : 0);
  int64_t freeBytes = -1, totalBytes = 0;
  if (device != nv::Device::Cuda || !nv::deviceMemoryInfo(freeBytes, totalBytes))
    freeBytes = -1;
  nv::checkMemory(estimate, "training this network",
    "Lower Log2TableSize (or set it to 0 for the automatic size), FinestResolution, Levels, FeaturesPerLevel or "
    "BatchSize",
    freeBytes);
}

/// The smallest valid network: a new session holds it until its job's run installs the real one (in the run's
/// thread), so that creating a session never copies a large table in the caller's thread.
nv::Model PlaceholderModel(const nv::ModelConfig& config)
{
  nv::ModelConfig small = config;
  small.encoding.levels = 1;
  small.encoding.featuresPerLevel = 1;
  small.encoding.log2TableSize = 10;
  small.encoding.finestResolution = small.encoding.baseResolution;
  small.network.width = 16;
  small.network.hiddenLayers = 1;
  return nv::Model(small);
}
/// A job's network that needs no training: `bytes` (deserialized: `model`), with the figures of the cache's `cached`
/// record, or restored from a state when null.
void ReuseNetwork(
  nvi::Job& job, const nvi::NetworkBytes& bytes, const nv::Model& model, const nvi::NetworkRecord* cached)
{
  auto record = std::make_shared<nvi::NetworkRecord>();
  record->Key = job.Key;
  record->Time = job.Time;
  record->Bytes = bytes;
  record->M = cached ? cached->M : nvi::MetricsOf(model, nv::deviceName(job.Session->device()));
  const bool restored = cached ? cached->M.Restored : true;
  record->M.Restored = restored;
  record->M.State = restored ? "Restored" : record->M.State;
  job.NetworkConfig = model.config();
  job.Source = model.source;
  job.SetFinal(record);
}
} // namespace

//------------------------------------------------------------------------------
void vtkNeuralCompress::StartJob(const nvi::FieldInfo& field, std::shared_ptr<nvi::TrainingData> data,
  const nvi::Settings& settings, uint64_t key, double time)
{
  vtkInternals& in = *this->Internals;
  auto job = std::unique_ptr<nvi::Job>(new nvi::Job);
  job->Key = key;
  job->Time = time;
  job->Field = field;
  job->S = settings;
  job->Data = data;
  job->OutputMode = this->OutputMode;
  job->Storage = settings.Precision == QUANTIZED8 ? nv::Precision::Quantized8
    : settings.Precision == FLOAT16              ? nv::Precision::Float16
                                                 : nv::Precision::Float32;
  in.SummaryPrinted = false;
  in.NotesPrinted = in.WarningsPrinted = 0;
  in.DecodeRequested = false;
  const nv::VolumeView& view = data->Field.View;
  const nv::ModelConfig config = NetworkConfigFor(settings, view.dims, data->Field.RawBytes, job->Storage);
  const nv::TrainConfig train = TrainConfigFor(settings, this->TrainInBackground != 0);
  job->Train = train;

  nv::Device requested = settings.Device == DEVICE_CPU ? nv::Device::Cpu
    : settings.Device == DEVICE_CUDA                  ? nv::Device::Cuda
                                                      : nv::Device::Auto;
  const nv::Device device = nv::resolveDevice(requested, &job->DeviceNote);

  CheckTrainingMemory(config, train, device, settings.Strategy == STRATEGY_GPU_RESIDENT ? view.bytes() : 0);
  job->NetworkConfig = config;
  job->Source = SourceOf(field, *data); // the geometry is checked now (as the network format does), not after training

  // A network this filter already has for this input and these settings (cached, or restored from a state): no
  // training.
  nvi::NetworkBytes stored;
  const nvi::NetworkRecord* cached = in.Cache.Find(time, key);
  if (cached && cached->M.State != "Interrupted")
    stored = cached->Bytes;
  auto restored = in.Restored.find(key);
  if (!stored && restored != in.Restored.end())
    stored = restored->second;
  const nv::Model storedModel =
    nvi::HasBytes(stored) ? nv::deserialize(stored->data(), stored->size()) : PlaceholderModel(config);

  nv::SessionOptions sessionOptions;
  sessionOptions.threads = settings.Threads;
  sessionOptions.lowPriority = this->TrainInBackground != 0; // its renders and measurements share the cores with training
  if (!in.Session || in.SessionDevice != static_cast<int>(device) || in.SessionThreads != settings.Threads)
  {
    in.Session = nv::NetworkSession::create(device, storedModel, sessionOptions);
    in.SessionDevice = static_cast<int>(device);
    in.SessionThreads = settings.Threads;
  }
  else if (nvi::HasBytes(stored))
  {
    in.Session->setModel(storedModel);
  }
  job->Session = in.Session;
  in.Current = std::move(job);
  nvi::Job& j = *in.Current;
  if (nvi::HasBytes(stored))
  {
    ReuseNetwork(j, stored, storedModel, cached && cached->Bytes == stored ? cached : nullptr);
    return;
  }

  // Training: the run installs the initial network in its own thread (Job::InstallInitialNetwork): a warm start
  // from the network of this very time step that another time step cut short, else of the nearest earlier one.
  if (this->WarmStart)
  {
    const nvi::NetworkRecord* seed =
      cached && cached->M.State == "Interrupted" ? cached : in.Cache.NearestForWarmStart(time);
    j.WarmSeed = seed ? seed->Bytes : nullptr;
  }
  const bool constant = !(field.Stats.max > field.Stats.min);
  if (constant || this->TrainingSteps == 0)
  {
    if (constant)
    {
      vtkWarningMacro("Neural Compress: '" << field.Name << "' is constant (" << field.Stats.min
                                           << "); it is represented exactly, training skipped.");
    }
    j.InstallInitialNetwork();
    j.FinalizeWithoutTraining();
    return;
  }
  this->StartRun(j, this->FirstPhaseLimits(field, *data), 0, false);
}

//------------------------------------------------------------------------------
nv::RunLimits vtkNeuralCompress::FirstPhaseLimits(const nvi::FieldInfo& field, const nvi::TrainingData& data) const
{
  nvi::RunLimits limits;
  limits.KeepBest = this->KeepBestNetwork;
  limits.MaxSteps = this->TrainingSteps;
  // The budget bounds the whole Apply: what preparing the field took is spent, and the run keeps time for the
  // measurement (and decode) at its end.
  limits.TimeBudget =
    this->Deterministic || this->TimeBudget <= 0.0 ? 0.0 : std::max(1e-3, this->TimeBudget - field.PreparationSeconds);
  const nv::VolumeView& fieldView = data.Field.View;
  const int* decodedDims = field.Geometry.DecodedDims;
  // The phase end (Job::Finalize) decodes the output field (decoded modes), measures the network over the field
  // (a float32 field decoded on the source's grid is compared as it is, without evaluating the network again) and at
  // a resampled input's own samples.
  const bool decodes = this->OutputMode != 0;
  const bool comparesDecoded = this->OutputMode == OUTPUT_FLOAT32 && field.Geometry.OnSourceGrid;
  limits.FinalSamples = (decodes ? int64_t(decodedDims[0]) * decodedDims[1] * decodedDims[2] : int64_t(0)) +
    (fieldView.data && !comparesDecoded ? fieldView.count() : int64_t(0)) +
    (field.Samples ? static_cast<int64_t>(field.Samples->Values.size()) : int64_t(0));
  limits.TargetPsnr = this->Deterministic ? 0.0 : this->TargetPSNR;
  limits.PsnrInterval = this->PSNRInterval > 0 ? this->PSNRInterval : (limits.TargetPsnr > 0.0 ? 100 : 0);
  return limits;
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::StartRun(nvi::Job& job, const nvi::RunLimits& limits, int64_t moreSteps, bool fastForward)
{
  if (limits.PsnrInterval > 0 && !job.Data->Probe)
  {
    // A sparse input has no dense field: its estimates come from its bank.
    job.Data->Probe.reset(job.Data->Field.View.data
        ? new nvi::PsnrProbe(job.Data->Field.View, job.Train.seed, 65536)
        : new nvi::PsnrProbe(job.Data->BankXyz, job.Data->BankValues, 65536));
  }
  nvi::Job* jobPtr = &job;
  if (this->TrainInBackground)
  {
    job.DecodeAbort = nullptr; // Retiring stops it (the filter may not be asked from the training thread)
    job.DecodeProgress = nullptr;
  }
  else
  {
    job.DecodeAbort = [this]() { return this->GetAbortExecute() != 0; };
    job.DecodeProgress = [this](double f) { this->UpdateProgress(0.95 + 0.05 * f); };
  }
  job.Run.reset(new nvi::TrainingRun(job.Session, job.Data, job.Train, limits,
    [jobPtr](nvi::TrainingRun&, const nvi::RunStatus& status) { jobPtr->Finalize(status); }));
  if (job.InitialNetworkPending())
    job.Run->SetPrologue([jobPtr]() { jobPtr->InstallInitialNetwork(); }); // in the run's thread
  job.Run->Extend(moreSteps, fastForward); // part of the first phase (Continue / Fast-forward on a network)
  if (this->TrainInBackground)
  {
    job.Run->StartInBackground();
  }
  else
  {
    job.Run->RunHere([this]() { return this->GetAbortExecute() != 0; },
      [this](double f) { this->UpdateProgress(0.95 * f); });
  }
}
