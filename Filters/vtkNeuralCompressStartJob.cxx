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
  job->Storage = this->StoragePrecision == QUANTIZED8 ? nv::Precision::Quantized8
    : this->StoragePrecision == FLOAT16              ? nv::Precision::Float16
                                                     : nv::Precision::Float32;
  in.SummaryPrinted = false;
  in.NotesPrinted = in.WarningsPrinted = 0;
  in.DecodeRequested = false;
  const nv::VolumeView& view = data->Field.View;
  const int64_t* dims = view.dims;

  // Model configuration.
  nv::ModelConfig config;
  config.encoding.levels = this->Levels;
  config.encoding.featuresPerLevel = this->FeaturesPerLevel;
  config.encoding.baseResolution = this->BaseResolution;
  config.encoding.perLevelScale = 0.0;
  // Default finest level: twice the largest dimension (never below the base resolution).
  config.encoding.finestResolution = this->FinestResolution > 0
    ? this->FinestResolution
    : static_cast<int>(std::max<int64_t>(2 * std::max({ dims[0], dims[1], dims[2] }), this->BaseResolution));
  config.network.width = this->NetworkWidth;
  config.network.hiddenLayers = this->HiddenLayers;
  config.encoding.log2TableSize = this->Log2TableSize > 0 ? this->Log2TableSize : 10;
  nv::validate(config);
  if (this->Log2TableSize <= 0)
  {
    // Automatic (TargetCompressionRatio 0): the largest table that still gives 10:1, else the smallest one.
    const double target = this->TargetCompressionRatio > 0.0 ? this->TargetCompressionRatio : 10.0;
    config.encoding.log2TableSize =
      nv::chooseLog2TableSize(config, data->Field.RawBytes, target, job->Storage);
  }

  nv::TrainConfig train;
  train.batchSize = this->BatchSize;
  train.seed = static_cast<uint64_t>(this->Seed);
  train.loss = this->Loss == LOSS_L2 ? nv::LossType::L2 : nv::LossType::L1;
  train.optimizer.learningRate = this->LearningRate;
  // Annealed: TrainingRun sets the planned steps (the run's length) before each chunk of steps.
  train.optimizer.schedule =
    this->LearningRateSchedule == ANNEALED ? nv::LearningRateSchedule::Auto : nv::LearningRateSchedule::StepDecay;
  train.optimizer.stepDecay = this->LearningRateSchedule == STEP_DECAY;
  train.threads = this->Threads;
  train.strategy = static_cast<nv::TrainingStrategy>(this->TrainingStrategy);
  train.deterministic = this->Deterministic;
  train.lowPriority = this->TrainInBackground != 0; // beside the GUI: its threads keep their share of the cores
  nv::validate(train);
  job->Train = train;

  nv::Device requested = this->Device == DEVICE_CPU ? nv::Device::Cpu
    : this->Device == DEVICE_CUDA                    ? nv::Device::Cuda
                                                     : nv::Device::Auto;
  const nv::Device device = nv::resolveDevice(requested, job->DeviceNote.empty() ? &job->DeviceNote : nullptr);

  // Memory: a network or a batch the machine cannot hold is refused before anything is allocated.
  {
    const bool uploaded = device == nv::Device::Cuda && this->TrainingStrategy == STRATEGY_GPU_RESIDENT;
    const nv::MemoryEstimate estimate = nv::trainingMemory(config, train, device, uploaded ? view.bytes() : 0);
    int64_t freeBytes = -1, totalBytes = 0;
    if (device != nv::Device::Cuda || !nv::deviceMemoryInfo(freeBytes, totalBytes))
      freeBytes = -1;
    nv::checkMemory(estimate, "training this network", "Lower Log2TableSize (or set it to 0 for the automatic size), "
      "FinestResolution, Levels, FeaturesPerLevel or BatchSize", freeBytes);
  }

  nv::Model model(config);
  nv::SourceInfo& src = model.source;
  for (int d = 0; d < 3; ++d)
  {
    // The trained field spans the source samples: the points, or the cell centres.
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
  src.rawBytes = data->Field.RawBytes;
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

  // The geometry the network will carry is checked now (as the network format does), not after training.
  try
  {
    nv::validate(model.source);
  }
  catch (const nv::Error& e)
  {
    throw nv::Error(std::string("the input's geometry cannot be stored with a network: ") + e.what() + ". " +
      nvi::SpacingAdvice(field.InputSpacing, dims));
  }

  // Warm start: the network of the nearest time step trained before, when its layout is the same.
  bool warm = false;
  if (this->WarmStart)
  {
    // A run of this very time step that another time step cut short goes on from where it was; else the network
    // of the nearest earlier time step.
    const nvi::NetworkRecord* own = in.Cache.Find(time, key);
    if (const nvi::NetworkRecord* seed =
          own && own->M.State == "Interrupted" ? own : in.Cache.NearestForWarmStart(time))
    {
      try
      {
        nv::Model previous = nv::deserialize(seed->Bytes);
        if (previous.params().size() == model.params().size() &&
          previous.config().encoding.log2TableSize == config.encoding.log2TableSize &&
          previous.config().network.width == config.network.width &&
          previous.config().network.hiddenLayers == config.network.hiddenLayers &&
          previous.config().encoding.levels == config.encoding.levels)
        {
          model.params() = previous.params();
          warm = true;
        }
      }
      catch (const nv::Error&)
      {
        warm = false;
      }
    }
  }
  if (!warm)
  {
    model.initialize(train.seed);
  }
  job->WarmStart = warm;
  job->Base = model;

  nv::SessionOptions sessionOptions;
  sessionOptions.threads = this->Threads;
  sessionOptions.lowPriority = this->TrainInBackground != 0; // its renders and measurements share the cores with training
  if (!in.Session || in.SessionDevice != static_cast<int>(device) || in.SessionThreads != this->Threads)
  {
    in.Session = nv::NetworkSession::create(device, model, sessionOptions);
    in.SessionDevice = static_cast<int>(device);
    in.SessionThreads = this->Threads;
  }
  else
  {
    in.Session->setModel(model);
  }
  job->Session = in.Session;
  in.Current = std::move(job);
  nvi::Job& j = *in.Current;

  // A network this filter already has for this input and these settings: no training.
  auto reuse = [&](const std::vector<uint8_t>& bytes, const nvi::Metrics* metrics, bool restored) {
    nv::Model stored = nv::deserialize(bytes);
    j.Session->setModel(stored);
    auto record = std::make_shared<nvi::NetworkRecord>();
    record->Key = key;
    record->Time = time;
    record->Bytes = bytes;
    if (metrics)
    {
      record->M = *metrics;
    }
    else
    {
      record->M = nvi::MetricsOf(stored, nv::deviceName(j.Session->device()));
    }
    record->M.Restored = restored;
    record->M.State = restored ? "Restored" : record->M.State;
    j.SetFinal(record);
  };
  if (const nvi::NetworkRecord* cached = in.Cache.Find(time, key))
  {
    if (cached->M.State != "Interrupted")
    {
      reuse(cached->Bytes, &cached->M, cached->M.Restored);
      j.Base = j.Session->currentModel();
      return;
    }
  }
  auto restored = in.Restored.find(key);
  if (restored != in.Restored.end())
  {
    reuse(restored->second, nullptr, true);
    j.Base = j.Session->currentModel();
    return;
  }

  // Training.
  const bool constant = !(field.Stats.max > field.Stats.min);
  if (constant || this->TrainingSteps == 0)
  {
    if (constant)
    {
      vtkWarningMacro("Neural Compress: '" << field.Name << "' is constant (" << field.Stats.min
                                           << "); it is represented exactly, training skipped.");
    }
    j.FinalizeWithoutTraining();
    return;
  }
  nvi::RunLimits limits;
  limits.KeepBest = this->KeepBestNetwork;
  limits.MaxSteps = this->TrainingSteps;
  // The budget bounds the whole Apply: what preparing the field took is spent, and the run keeps time for the
  // measurement (and decode) at its end.
  limits.TimeBudget =
    this->Deterministic || this->TimeBudget <= 0.0 ? 0.0 : std::max(1e-3, this->TimeBudget - field.PreparationSeconds);
  const nv::VolumeView& fieldView = data->Field.View;
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
  this->StartRun(j, limits, 0, false);
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
