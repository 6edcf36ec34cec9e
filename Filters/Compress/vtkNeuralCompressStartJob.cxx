// vtkNeuralCompress: a new job -- its engine configuration (from the settings snapshot), the session, warm start,
// a cached or restored network or a training run.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressSettings.h"
#include "vtkNeuralCompressState.h"
#include "vtkNeuralOutOfCoreInput.h"

#include "Core/Error.h"
#include "Core/ResourceEstimate.h"
#include "Core/Serialization.h"

#include "vtkDataArray.h"

#include <algorithm>
#include <chrono>

namespace
{
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
void CheckTrainingMemory(const nv::ModelConfig& config, const nv::TrainConfig& train, nv::Device device,
  int cudaDevice, int64_t fieldBytes)
{
  const nv::MemoryEstimate estimate =
    nv::trainingMemory(config, train, device, device == nv::Device::Cuda ? fieldBytes : 0);
  int64_t freeBytes = -1, totalBytes = 0;
  if (device != nv::Device::Cuda || !nv::deviceMemoryInfo(freeBytes, totalBytes, cudaDevice))
    freeBytes = -1;
  nv::checkMemory(estimate, "training this network",
    "Lower Log2TableSize (or set it to 0 for the automatic size), FinestResolution, Levels, FeaturesPerLevel or "
    "BatchSize",
    freeBytes);
}

/// An out-of-core input's automatic network keeps its host training memory (nv::trainingMemory: parameters, gradients,
/// moments, the session's copies) within an eighth of the MemoryBudget, so that the process stays within the budget
/// and that share whatever the file's size (sized for 10:1 of a 41 GB file, the network held 14 GB beside an 8 GiB
/// budget). Returns what it did ("" when the automatic size fits).
std::string FitOutOfCoreNetwork(
  nv::ModelConfig& config, const nv::TrainConfig& train, nv::Device device, int64_t budgetBytes)
{
  const int64_t share = budgetBytes / 8;
  const int chosen = config.encoding.log2TableSize;
  while (config.encoding.log2TableSize > 10 && nv::trainingMemory(config, train, device).hostBytes > share)
    --config.encoding.log2TableSize;
  if (config.encoding.log2TableSize == chosen)
    return std::string();
  return "automatic table 2^" + std::to_string(config.encoding.log2TableSize) + " (2^" + std::to_string(chosen) +
    " for the ratio): its training memory within an eighth of the MemoryBudget (" + nv::formatBytes(share) + ")";
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
  record->Figures = cached ? cached->Figures : nvi::MetricsOf(model, nv::deviceName(job.Session->device()));
  if (!cached)
    record->Figures.CudaDevice = job.Session->cudaDevice();
  const bool restored = cached ? cached->Figures.Restored : true;
  record->Figures.Restored = restored;
  record->Figures.State = restored ? "Restored" : record->Figures.State;
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
  job->TrainingSettings = settings;
  job->Data = data;
  job->OutputMode = this->OutputMode;
  in.SummaryPrinted = false;
  in.NotesPrinted = in.WarningsPrinted = 0;
  in.DecodeRequested = false;
  // Every engine configuration from the settings snapshot, nothing from the filter's properties.
  const nv::VolumeView& view = data->Field.View;
  nvi::EngineConfigs configs =
    nvi::EngineConfigsFor(settings, view.dims, data->Field.RawBytes, this->TrainInBackground != 0);
  job->Storage = configs.Storage;
  job->Train = configs.Train;
  job->SessionOptions = configs.Session;
  job->SearchMaxLog2 = configs.SearchMaxLog2;
  const nv::Device device =
    nv::resolveDevice(configs.RequestedDevice, &job->DeviceNote, configs.Session.cudaDevice);
  if (field.OutOfCore && settings.Log2TableSize <= 0)
    job->SizeNote = FitOutOfCoreNetwork(configs.Network, configs.Train, device, field.OutOfCore->BudgetBytes);
  // An out-of-core field stays in its file: nothing of it is uploaded (its batches are host-sampled).
  CheckTrainingMemory(configs.Network, configs.Train, device, configs.Session.cudaDevice,
    configs.GpuResident && !field.OutOfCore ? view.bytes() : 0);
  job->NetworkConfig = configs.Network;
  job->Source = SourceOf(field, *data); // the geometry is checked now (as the network format does), not after training

  // A network this filter already has for this input and these settings (cached, or restored from a state): no
  // training.
  nvi::NetworkBytes stored;
  const nvi::NetworkRecord* cached = in.StoredNetwork(time, key, stored);
  const nv::Model storedModel =
    nvi::HasBytes(stored) ? nv::deserialize(stored->data(), stored->size()) : PlaceholderModel(configs.Network);
  in.UseSession(device, configs.Session, storedModel, nvi::HasBytes(stored));
  job->Session = in.Session;
  in.Current = std::move(job);
  nvi::Job& current = *in.Current;
  if (nvi::HasBytes(stored))
  {
    ReuseNetwork(current, stored, storedModel, cached && cached->Bytes == stored ? cached : nullptr);
    return;
  }
  this->StartTraining(current, cached);
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::StartTraining(nvi::Job& job, const nvi::NetworkRecord* cached)
{
  vtkInternals& in = *this->Internals;
  const nvi::Settings& settings = job.TrainingSettings;
  // The run installs the initial network in its own thread (Job::InstallInitialNetwork): a warm start from the
  // network of this very time step that another time step cut short, else of the nearest earlier one.
  if (settings.WarmStart)
  {
    const nvi::NetworkRecord* seed =
      cached && cached->Figures.State == "Interrupted" ? cached : in.Cache.NearestForWarmStart(job.Time);
    job.WarmSeed = seed ? seed->Bytes : nullptr;
  }
  const nvi::FieldInfo& field = job.Field;
  const bool constant = !(field.Stats.max > field.Stats.min);
  if (constant || settings.TrainingSteps == 0)
  {
    if (constant)
    {
      vtkWarningMacro("Neural Compress: '" << field.Name << "' is constant (" << field.Stats.min
                                           << "); it is represented exactly, training skipped.");
    }
    job.InstallInitialNetwork();
    job.FinalizeWithoutTraining();
    return;
  }
  this->StartRun(job, nvi::FirstPhaseLimits(settings, field, *job.Data, this->OutputMode), 0, false);
}

//------------------------------------------------------------------------------
const nvi::NetworkRecord* vtkNeuralCompress::vtkInternals::StoredNetwork(
  double time, uint64_t key, nvi::NetworkBytes& stored)
{
  const nvi::NetworkRecord* cached = this->Cache.Find(time, key);
  if (cached && cached->Figures.State != "Interrupted")
    stored = cached->Bytes;
  auto restored = this->Restored.find(key);
  if (!stored && restored != this->Restored.end())
    stored = restored->second;
  return cached;
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::vtkInternals::UseSession(
  nv::Device device, const nv::SessionOptions& options, const nv::Model& storedModel, bool haveStored)
{
  if (!this->Session || this->SessionDevice != static_cast<int>(device) || this->SessionThreads != options.threads ||
    this->SessionCudaDevice != options.cudaDevice)
  {
    this->Session = nv::NetworkSession::create(device, storedModel, options);
    this->SessionDevice = static_cast<int>(device);
    this->SessionThreads = options.threads;
    this->SessionCudaDevice = options.cudaDevice;
  }
  else if (haveStored)
  {
    this->Session->setModel(storedModel);
  }
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
  {
    // In the run's thread: SizeForPSNR's search (stopped by a Stop, an abort or a replacing job), then the network.
    job.Run->setPrologue([jobPtr]() {
      const auto searchStarted = std::chrono::steady_clock::now();
      jobPtr->SearchSizeForPsnr([jobPtr]() {
        return jobPtr->Retiring.load() || (jobPtr->DecodeAbort && jobPtr->DecodeAbort()) ||
          jobPtr->Run->status().State == nvi::RunState::Finishing; // stop() before the first step
      });
      // The search is not the network's training: the TimeBudget is the network's after it (it had left the network
      // 27 of 400 steps when the search of a 80^3 Wavelet took 54 of the 60 s default on the CPU).
      jobPtr->Run->excludeFromBudget(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - searchStarted).count());
      jobPtr->InstallInitialNetwork();
    });
  }
  job.Run->extend(moreSteps, fastForward); // part of the first phase (Continue / Fast-forward on a network)
  if (this->Internals->StopBeforeStart)
  {
    job.Run->stop(); // the user stopped while the field was prepared: the run ends before its first step
    this->Internals->StopBeforeStart = false;
  }
  if (this->TrainInBackground)
  {
    job.Run->startInBackground();
  }
  else
  {
    job.Run->runHere([this]() { return this->GetAbortExecute() != 0; },
      [this](double f) { this->UpdateProgress(0.95 * f); });
  }
}
