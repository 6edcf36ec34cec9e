// NeuralVolume engine: model and training configuration (VTK-free).
#pragma once

#include <cstdint>
#include <string>

namespace nv
{

/// Multiresolution hash-grid encoding (Mueller et al. 2022, as used by Wu et al. 2023).
struct EncodingConfig
{
  int levels = 16;           ///< number of resolution levels, 1..32
  int featuresPerLevel = 4;  ///< 1, 2, 4 or 8
  int log2TableSize = 19;    ///< entries per hashed level = 2^log2TableSize, 10..26
  int baseResolution = 16;   ///< coarsest grid resolution, >= 2
  /// Growth factor between levels. If <= 0 it is derived from finestResolution:
  /// (finest / base)^(1 / (levels - 1)).
  double perLevelScale = 0.0;
  int finestResolution = 4096; ///< used only when perLevelScale <= 0

  int outputDims() const { return levels * featuresPerLevel; }
  /// The per-level scale actually used.
  double effectivePerLevelScale() const;
};

/// Fully connected ReLU network without biases; linear scalar output.
struct NetworkConfig
{
  int width = 64;        ///< 16, 32, 64 or 128
  int hiddenLayers = 4;  ///< 1..8
};

struct ModelConfig
{
  EncodingConfig encoding;
  NetworkConfig network;
};

enum class LossType : int
{
  L1 = 0,
  L2 = 1
};

/// How the learning rate falls over a run (OptimizerConfig::schedule).
enum class LearningRateSchedule : int
{
  StepDecay = 0,   ///< x decayFactor every decayInterval steps (the paper's; stepDecay false: constant)
  Exponential = 1, ///< learningRate * finalRateFraction^(step / plannedSteps), then constant past plannedSteps
  Cosine = 2,      ///< half a cosine from learningRate down to learningRate * finalRateFraction at plannedSteps
                   ///< (both annealed schedules start after holdSteps)
  /// The default: Cosine when plannedSteps > 0 (a run of known length), else StepDecay. Measured
  /// (Testing/Benchmarks/results/tradeoff_2026-11-24/anneal_cpu.md, anneal_gpu.md): the cosine to 1/100 ends within
  /// 0.7 dB of its best probe on every real volume, where the step decay ended up to 11 dB below it.
  Auto = 3
};

/// Adam, lr 1e-2. The default schedule (Auto) anneals over plannedSteps when the caller sets them (cosine to 1/100),
/// else it is the paper's step decay (x0.8 every 1000 steps).
struct OptimizerConfig
{
  double learningRate = 1e-2;
  double beta1 = 0.9;
  double beta2 = 0.99;
  double epsilon = 1e-15;
  bool stepDecay = true;     ///< false: constant learning rate
  int decayInterval = 1000;  ///< steps
  double decayFactor = 0.8;
  /// Linear warm-up: the rate grows from learningRate / warmupSteps to learningRate over the first warmupSteps
  /// steps (0: none).
  int warmupSteps = 0;
  /// Loss-driven decay (PlateauSchedule.h): windows of this many steps; a window whose mean loss is not 1% below
  /// the best window's halves the rate, down to 1/64 (0: off).
  int plateauWindow = 0;
  LearningRateSchedule schedule = LearningRateSchedule::Auto;
  /// The number of steps this trainer is planned to take (finite, >= 0; Exponential and Cosine need > 0): the
  /// annealed rate reaches learningRate * finalRateFraction there and stays. A run of TrainingSteps passes the steps
  /// it will take; a time-budget run an estimate (from its measured step rate). 0: not known (Auto: StepDecay).
  double plannedSteps = 0.0;
  double finalRateFraction = 0.01; ///< annealed schedules: the rate at plannedSteps / learningRate, in (0, 1]
  /// Annealed schedules: the rate stays learningRate for the first holdSteps steps (for all of a run planned no
  /// longer), then anneals over the rest of plannedSteps (>= 0). A short run trains at the full rate as with the step
  /// decay (annealed from its first step, a 300-step run on a 99.9% empty field stayed at the zero field: 34.4 dB
  /// against 41.1); a long one anneals over most of it (Testing/Benchmarks/results/tradeoff_2026-11-25).
  int holdSteps = 500;

  /// The schedule in effect (Auto resolved: never Auto).
  LearningRateSchedule effectiveSchedule() const;
  /// Learning rate used by (1-based) step `step`.
  double learningRateAt(int64_t step) const;
};

enum class Device : int
{
  Auto = 0,
  Cpu = 1,
  Cuda = 2
};

const char* deviceName(Device d);

/// Where the arrays passed to an engine call live.
enum class Memory : int
{
  Host = 0,
  Device = 1 ///< memory of the session's GPU (CUDA backend only)
};

/// Where training targets are sampled (the paper's Sections 4.1-4.2). CPU training always samples on the host.
enum class TrainingStrategy : int
{
  Auto = 0,        ///< GPU-resident when the volume fits in GPU memory, else host-sampled
  GpuResident = 1, ///< volume uploaded once (native type or fp16); targets sampled on the GPU
  HostSampled = 2  ///< CPU threads sample the next batch while the GPU trains on the current one
};

struct TrainConfig
{
  int batchSize = 65536;
  uint64_t seed = 1;
  LossType loss = LossType::L1;
  OptimizerConfig optimizer;
  int threads = 0; ///< CPU worker threads; 0 = hardware concurrency
  TrainingStrategy strategy = TrainingStrategy::Auto; ///< used by the CUDA trainer
  /// CUDA trainer: sum gradients in 64-bit fixed point so that a seed gives the same network bit for bit on the
  /// same GPU and build (slower: one integer atomic per feature). The CPU trainer is deterministic for a seed and
  /// thread count in either mode.
  bool deterministic = false;
  /// Error-guided sampling (Core/ImportanceGrid.h): cells per axis of the grid of per-cell errors that draws half
  /// of each batch where the network is worst; 0 = uniform sampling. Volumes only (not banks of points, nor the
  /// CUDA trainer's host-sampled strategy).
  int importanceGrid = 0;
  /// The run's CPU threads (the CPU trainer's workers and a background run's own thread) run at a lower scheduling
  /// priority (ThreadPriority.h): an interactive application beside them keeps its share of the cores.
  bool lowPriority = false;
  /// Quantisation-aware fine-tuning for 8-bit storage (Precision::Quantized8): the last `quantizationAwareFraction` of
  /// the planned steps (OptimizerConfig::plannedSteps; none when it is 0), where an annealed rate has left its hold
  /// (OptimizerConfig::holdSteps; none with the step decay), train through the stored network: the
  /// forward pass reads each hash-table entry as its 8-bit code's value (the level's step chosen as Model::quantize
  /// chooses it, from the float entries of that step) and the MLP weights rounded to fp16; the gradients update the
  /// float parameters (a straight-through estimator). In [0, 1]; 0: off. The CPU trainer only.
  double quantizationAwareFraction = 0.0;
};

/// Throws nv::Error with a readable message when a configuration is out of range.
void validate(const ModelConfig& config);
void validate(const TrainConfig& config);

} // namespace nv
