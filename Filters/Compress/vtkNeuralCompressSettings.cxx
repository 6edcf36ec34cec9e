// The one source of truth for a job's settings (vtkNeuralCompressSettings.h): the filter's properties copied into a
// Settings snapshot, and every engine configuration of the job made from that snapshot only.
#include "vtkNeuralCompressSettings.h"

#include "vtkNeuralCompress.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCudaDevice.h"

#include "Core/ResourceEstimate.h"

#include <algorithm>
#include <sstream>

namespace nvi = vtkNeuralCompressInternals;

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
  s.MemoryBudgetMiB = this->MemoryBudget;
  s.BypassPageCache = this->BypassPageCache != 0;
  s.MaxError = this->MaxError;
  s.SizeForPsnr = this->SizeForPSNR;
  s.ParticleField = this->ParticleField;
  s.ParticleKernel = this->ParticleKernel;
  s.ParticleRadius = this->ParticleRadius;
  s.ParticleRadiusArray = this->ParticleRadiusArray;
  return s;
}

namespace vtkNeuralCompressInternals
{

//------------------------------------------------------------------------------
std::string Settings::Canonical() const
{
  std::ostringstream s;
  s.precision(17);
  s << "v1 " << VectorMode << ' ' << VectorComponent << ' ' << TrainingSteps << ' '
    << (Deterministic ? 0.0 : TimeBudget) << ' ' << LearningRate << ' ' << TargetCompressionRatio << ' '
    << (Deterministic ? 0.0 : TargetPsnr) << ' ' << BatchSize << ' ' << Seed << ' ' << Loss << ' ' << Schedule
    << ' ' << Levels << ' ' << Features << ' ' << Log2TableSize << ' ' << BaseResolution << ' '
    << FinestResolution << ' ' << Width << ' ' << HiddenLayers << ' ' << Precision << ' ' << Device << ' '
    << (Deterministic ? Threads : 0) << ' ' << Strategy << ' ' << "0 0 0" // v1's OutputResolution: no longer a setting
    << ' ' << PsnrInterval << ' ' << Deterministic << ' ' << WarmStart;
  if (Sampling != 0)
    s << " probe " << ProbePoints; // Resample keeps the v1 string, so saved states' keys stay valid
  if (!KeepBest)
    s << " last"; // the default keeps the v1 string too
  if (MemoryBudgetMiB != 0.0)
    s << " memory " << MemoryBudgetMiB; // out-of-core inputs only (others train with 0)
  if (MaxError != 0.0)
    s << " maxerror " << MaxError; // the corrections are part of the stored network; off keeps the v1 string
  if (SizeForPsnr != 0.0 && Log2TableSize <= 0)
    s << " sizepsnr " << SizeForPsnr; // the searched size; off (or a set table size) keeps the v1 string
  if (ParticleField != 0 || ParticleKernel != 1 || ParticleRadius != 0.0 || !ParticleRadiusArray.empty())
    s << " particles " << ParticleField << ' ' << ParticleKernel << ' ' << ParticleRadius << " [" << ParticleRadiusArray
      << ']'; // the defaults keep the v1 string
  return s.str();
}

namespace
{
/// The share of the planned steps that 8-bit storage fine-tunes through the stored network (TrainConfig; within the
/// annealed part only). Half won more than a fifth (nucleon, 2000 CPU steps: 8-bit 41.26 dB without, 41.31 with a
/// fifth, 41.89 with half; a 32^3 synthetic field at 600 steps, mean of 3 seeds: +0.06 and +0.14 dB); where 8-bit
/// costs little it moves the PSNR within noise (headsq, walnut at 1000 steps: -0.06, -0.03 dB).
constexpr double kQuantizationAwareFraction = 0.5;

/// The storage precision set (Automatic: fp16 until the automatic size chooses, NetworkConfigOf).
nv::Precision StorageOf(const Settings& s)
{
  return s.Precision == vtkNeuralCompress::QUANTIZED8 ? nv::Precision::Quantized8
    : s.Precision == vtkNeuralCompress::FLOAT32      ? nv::Precision::Float32
                                                     : nv::Precision::Float16;
}

nv::Device RequestedDeviceOf(const Settings& s)
{
  return s.Device == vtkNeuralCompress::DEVICE_CPU ? nv::Device::Cpu
    : s.Device == vtkNeuralCompress::DEVICE_CUDA  ? nv::Device::Cuda
                                                  : nv::Device::Auto;
}

/// The network's layout from the settings and the trained field's size, and its storage: an automatic table size
/// (and, with Automatic storage, precision) from the target ratio (nv::chooseAutomaticSize).
nv::ModelConfig NetworkConfigOf(const Settings& s, const int64_t* dims, int64_t rawBytes, nv::Precision& storage)
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
  if (SizedForPsnr(s))
  {
    // Searched by training (the job, nv::searchSizeForPsnr) in this storage: 8-bit for Automatic. The smallest table
    // until then.
    storage = s.Precision == vtkNeuralCompress::AUTOMATIC_PRECISION ? nv::Precision::Quantized8 : storage;
  }
  else if (s.Log2TableSize <= 0)
  {
    // Automatic (TargetCompressionRatio 0): the largest table that still gives 10:1 (in 8-bit codes with Automatic
    // storage), else, for a small input, the largest that still compresses (1:1); an explicit target out of reach:
    // the smallest.
    const bool targetIsDefault = !(s.TargetCompressionRatio > 0.0);
    const double target = targetIsDefault ? 10.0 : s.TargetCompressionRatio;
    const nv::AutomaticSize size = nv::chooseAutomaticSize(
      config, rawBytes, target, targetIsDefault, s.Precision == vtkNeuralCompress::AUTOMATIC_PRECISION, storage);
    config.encoding.log2TableSize = size.log2TableSize;
    storage = size.storage;
  }
  return config;
}

nv::TrainConfig TrainConfigOf(const Settings& s, bool lowPriority)
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
} // namespace

//------------------------------------------------------------------------------
EngineConfigs EngineConfigsFor(const Settings& settings, const int64_t dims[3], int64_t rawBytes, bool lowPriority)
{
  EngineConfigs configs;
  configs.Storage = StorageOf(settings);
  configs.Network = NetworkConfigOf(settings, dims, rawBytes, configs.Storage);
  configs.Train = TrainConfigOf(settings, lowPriority);
  if (configs.Storage == nv::Precision::Quantized8)
  {
    // The last half of the steps (where the rate anneals) trains through the 8-bit network (the CPU trainer; the CUDA
    // one ignores it): the stored network loses less (TestQuantizationAware; results/qat_2026-11-27.md).
    configs.Train.quantizationAwareFraction = kQuantizationAwareFraction;
  }
  configs.RequestedDevice = RequestedDeviceOf(settings);
  configs.Session.threads = settings.Threads;
  configs.Session.lowPriority = lowPriority; // its renders and measurements share the cores with training
  configs.Session.cudaDevice = vtkNeuralCudaDevice::Get(); // under MPI: this rank's GPU
  configs.GpuResident = settings.Strategy == vtkNeuralCompress::STRATEGY_GPU_RESIDENT;
  if (SizedForPsnr(settings))
  {
    // The candidates: 2^10 up to the largest table that still compresses the field (estimated ratio >= 1).
    configs.SearchMaxLog2 = nv::chooseLog2TableSize(configs.Network, rawBytes, 1.0, configs.Storage);
  }
  return configs;
}

//------------------------------------------------------------------------------
RunLimits FirstPhaseLimits(const Settings& settings, const FieldInfo& field, const TrainingData& data, int outputMode)
{
  RunLimits limits;
  limits.KeepBest = settings.KeepBest;
  limits.MaxSteps = settings.TrainingSteps;
  // The budget bounds the whole Apply: what preparing the field took is spent, and the run keeps time for the
  // measurement (and decode) at its end.
  limits.TimeBudget = settings.Deterministic || settings.TimeBudget <= 0.0
    ? 0.0
    : std::max(1e-3, settings.TimeBudget - field.PreparationSeconds);
  const nv::VolumeView& fieldView = data.Field.View;
  const int* decodedDims = field.Geometry.DecodedDims;
  // The phase end (Job::Finalize) decodes the output field (decoded modes), measures the network over the field
  // (a float32 field decoded on the source's grid is compared as it is, without evaluating the network again) and at
  // a resampled input's own samples.
  const bool decodes = outputMode != 0;
  const bool comparesDecoded = outputMode == vtkNeuralCompress::OUTPUT_FLOAT32 && field.Geometry.OnSourceGrid;
  limits.FinalSamples = (decodes ? int64_t(decodedDims[0]) * decodedDims[1] * decodedDims[2] : int64_t(0)) +
    (fieldView.data && !comparesDecoded ? fieldView.count() : int64_t(0)) +
    (field.Samples ? static_cast<int64_t>(field.Samples->Values.size()) : int64_t(0)) +
    (field.OutOfCore ? fieldView.count() : int64_t(0)); // the streamed pass over every voxel of the file
  limits.TargetPsnr = settings.Deterministic ? 0.0 : settings.TargetPsnr;
  limits.PsnrInterval =
    settings.PsnrInterval > 0 ? settings.PsnrInterval : (limits.TargetPsnr > 0.0 ? 100 : 0);
  return limits;
}

//------------------------------------------------------------------------------
RunLimits ContinuedRunLimits(const Settings& settings, int64_t firstStep)
{
  RunLimits limits;
  limits.KeepBest = settings.KeepBest;
  limits.PsnrInterval = settings.PsnrInterval;
  limits.FirstStep = firstStep;
  limits.MaxSteps = firstStep;
  return limits;
}

} // namespace vtkNeuralCompressInternals
