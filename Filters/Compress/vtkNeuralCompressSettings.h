// Private to NeuralVolume::Filters: the one source of truth for a job's settings. vtkNeuralCompress's properties are
// copied once into a Settings snapshot (vtkNeuralCompress::CurrentSettings, at the execution that asks for a
// training); the training key and every engine configuration of the job (network layout, optimiser, storage
// precision, device, session, run limits) are made from that snapshot only, here.
#ifndef vtkNeuralCompressSettings_h
#define vtkNeuralCompressSettings_h

#include "vtkNeuralCompressInternals.h"

#include <cstdint>
#include <string>

namespace vtkNeuralCompressInternals
{
struct FieldInfo;

/// The filter's properties that decide the trained network (not the controls, the output mode or the cache size).
struct Settings
{
  int VectorMode = 0, VectorComponent = 0;
  int64_t TrainingSteps = 0;
  double TimeBudget = 0.0, LearningRate = 0.0, TargetCompressionRatio = 0.0, TargetPsnr = 0.0;
  int BatchSize = 0, Seed = 0, Loss = 0, Schedule = 0;
  int Levels = 0, Features = 0, Log2TableSize = 0, BaseResolution = 0, FinestResolution = 0;
  int Width = 0, HiddenLayers = 0, Precision = 0, Device = 0, Threads = 0, Strategy = 0;
  int PsnrInterval = 0;
  bool Deterministic = false, WarmStart = true;
  int Sampling = 0, ProbePoints = 0; ///< non-image inputs (vtkNeuralCompress::SamplingModes)
  bool KeepBest = true;
  double MemoryBudgetMiB = 0.0; ///< out-of-core inputs (vtkNeuralOutOfCoreInput.h); 0: automatic
  bool BypassPageCache = false; ///< out-of-core inputs: the block buffer reads with O_DIRECT (not in the key)
  double MaxError = 0.0; ///< the error-bounded mode's bound in data units (nv::ErrorCorrections); 0: off
  double SizeForPsnr = 0.0; ///< the automatic size searched for this PSNR (nv::searchSizeForPsnr); 0: off
  /// Particle inputs (vtkNeuralCompressParticles.h).
  int ParticleField = 0, ParticleKernel = 1;
  double ParticleRadius = 0.0;
  std::string ParticleRadiusArray;
  /// Every field, for the training key.
  std::string Canonical() const;
};

/// The engine's configuration of one job, every part of it from one Settings snapshot (EngineConfigsFor).
struct EngineConfigs
{
  nv::ModelConfig Network; ///< the network's layout (an automatic table size from the target ratio)
  nv::TrainConfig Train;   ///< the optimiser settings
  nv::Precision Storage = nv::Precision::Float16; ///< the precision the network is stored (shown, saved) in
  nv::Device RequestedDevice = nv::Device::Auto;  ///< before nv::resolveDevice
  nv::SessionOptions Session;                     ///< the options of a session created for the job
  bool GpuResident = false; ///< the field is uploaded to the GPU with the network (its memory counts)
  /// SizedForPsnr: the largest table size the search may try (the smallest is Network's, 2^10); 0 otherwise.
  int SearchMaxLog2 = 0;
};

/// True when the job's table size is searched for a PSNR (SizeForPsnr set, Log2TableSize Automatic).
inline bool SizedForPsnr(const Settings& settings)
{
  return settings.SizeForPsnr > 0.0 && settings.Log2TableSize <= 0;
}

/// Every engine configuration of a job from `settings` and the trained field's size (`dims`, `rawBytes`);
/// `lowPriority`: training beside the GUI (TrainInBackground), its threads keep their share of the cores. Throws
/// nv::Error for settings the engine refuses.
EngineConfigs EngineConfigsFor(const Settings& settings, const int64_t dims[3], int64_t rawBytes, bool lowPriority);

/// The first phase's limits: steps, the time budget left after preparing `field`, the reserve for the phase end's
/// measurement and decode (`outputMode`: vtkNeuralCompress::OutputMode), target PSNR and probes.
RunLimits FirstPhaseLimits(
  const Settings& settings, const FieldInfo& field, const TrainingData& data, int outputMode);

/// The limits of a run that trains a cached or restored network further (Continue, Fast-forward): its step count
/// goes on from `firstStep`.
RunLimits ContinuedRunLimits(const Settings& settings, int64_t firstStep);

} // namespace vtkNeuralCompressInternals

#endif
