#include "Config.h"

#include "Error.h"

#include <algorithm>
#include <cmath>

namespace nv
{

double EncodingConfig::effectivePerLevelScale() const
{
  if (perLevelScale > 0.0)
  {
    return perLevelScale;
  }
  if (levels <= 1)
  {
    return 1.0;
  }
  return std::pow(static_cast<double>(finestResolution) / baseResolution, 1.0 / (levels - 1));
}

LearningRateSchedule OptimizerConfig::effectiveSchedule() const
{
  if (schedule != LearningRateSchedule::Auto)
    return schedule;
  return plannedSteps > 0.0 ? LearningRateSchedule::Cosine : LearningRateSchedule::StepDecay;
}

double OptimizerConfig::learningRateAt(int64_t step) const
{
  const double warm =
    warmupSteps > 0 && step < warmupSteps ? static_cast<double>(std::max<int64_t>(step, 1)) / warmupSteps : 1.0;
  const LearningRateSchedule s = effectiveSchedule();
  if (s == LearningRateSchedule::Exponential || s == LearningRateSchedule::Cosine)
  {
    const double hold = static_cast<double>(holdSteps);
    if (plannedSteps <= hold)
      return learningRate * warm; // a run no longer than the hold: the full rate throughout
    const double t = std::min(std::max(static_cast<double>(step) - hold, 0.0) / (plannedSteps - hold), 1.0);
    const double f = s == LearningRateSchedule::Exponential
      ? std::pow(finalRateFraction, t)
      : finalRateFraction + (1.0 - finalRateFraction) * 0.5 * (1.0 + std::cos(3.14159265358979323846 * t));
    return learningRate * warm * f;
  }
  if (!stepDecay || decayInterval <= 0 || step <= 0)
  {
    return learningRate * warm;
  }
  return learningRate * warm * std::pow(decayFactor, static_cast<double>((step - 1) / decayInterval));
}

const char* deviceName(Device d)
{
  switch (d)
  {
    case Device::Auto:
      return "Auto";
    case Device::Cpu:
      return "CPU";
    case Device::Cuda:
      return "CUDA";
  }
  return "?";
}

void validate(const ModelConfig& c)
{
  const EncodingConfig& e = c.encoding;
  NV_CHECK(e.levels >= 1 && e.levels <= 32, "levels must be in 1..32, got " + std::to_string(e.levels));
  NV_CHECK(e.featuresPerLevel == 1 || e.featuresPerLevel == 2 || e.featuresPerLevel == 4 || e.featuresPerLevel == 8,
    "features per level must be 1, 2, 4 or 8, got " + std::to_string(e.featuresPerLevel));
  NV_CHECK(e.log2TableSize >= 10 && e.log2TableSize <= 26,
    "log2 table size must be in 10..26, got " + std::to_string(e.log2TableSize));
  NV_CHECK(e.baseResolution >= 2 && e.baseResolution <= 4096,
    "base resolution must be in 2..4096, got " + std::to_string(e.baseResolution));
  if (e.perLevelScale <= 0.0)
  {
    NV_CHECK(e.finestResolution >= e.baseResolution && e.finestResolution <= (1 << 20),
      "finest resolution must be >= base resolution and <= 2^20, got " + std::to_string(e.finestResolution));
  }
  else
  {
    NV_CHECK(e.perLevelScale >= 1.0 && e.perLevelScale <= 4.0, "per-level scale must be in [1, 4]");
  }
  const int w = c.network.width;
  NV_CHECK(w == 16 || w == 32 || w == 64 || w == 128, "network width must be 16, 32, 64 or 128, got " + std::to_string(w));
  NV_CHECK(c.network.hiddenLayers >= 1 && c.network.hiddenLayers <= 8,
    "hidden layers must be in 1..8, got " + std::to_string(c.network.hiddenLayers));
}

void validate(const TrainConfig& c)
{
  NV_CHECK(c.batchSize >= 1 && c.batchSize <= (1 << 24), "batch size must be in 1..2^24");
  NV_CHECK(c.optimizer.learningRate > 0.0 && std::isfinite(c.optimizer.learningRate), "learning rate must be > 0");
  NV_CHECK(c.optimizer.beta1 >= 0.0 && c.optimizer.beta1 < 1.0, "beta1 must be in [0,1)");
  NV_CHECK(c.optimizer.beta2 >= 0.0 && c.optimizer.beta2 < 1.0, "beta2 must be in [0,1)");
  NV_CHECK(c.optimizer.epsilon >= 0.0, "epsilon must be >= 0");
  NV_CHECK(c.optimizer.warmupSteps >= 0, "warm-up steps must be >= 0");
  NV_CHECK(c.optimizer.plateauWindow >= 0, "the plateau window must be >= 0 steps");
  const OptimizerConfig& o = c.optimizer;
  NV_CHECK(o.schedule == LearningRateSchedule::StepDecay || o.schedule == LearningRateSchedule::Exponential ||
      o.schedule == LearningRateSchedule::Cosine || o.schedule == LearningRateSchedule::Auto,
    "unknown learning-rate schedule " + std::to_string(static_cast<int>(o.schedule)));
  NV_CHECK(std::isfinite(o.plannedSteps) && o.plannedSteps >= 0.0,
    "the planned number of steps must be a finite number >= 0, got " + std::to_string(o.plannedSteps));
  if (o.schedule == LearningRateSchedule::Exponential || o.schedule == LearningRateSchedule::Cosine)
  {
    NV_CHECK(o.plannedSteps > 0.0,
      "the annealed learning-rate schedule needs the planned number of steps (OptimizerConfig::plannedSteps > 0): "
      "the run's step count, or an estimate for a time budget");
  }
  if (o.effectiveSchedule() != LearningRateSchedule::StepDecay)
  {
    NV_CHECK(std::isfinite(o.finalRateFraction) && o.finalRateFraction > 0.0 && o.finalRateFraction <= 1.0,
      "the final learning-rate fraction must be in (0, 1], got " + std::to_string(o.finalRateFraction));
    NV_CHECK(o.holdSteps >= 0, "the steps before the rate anneals must be >= 0, got " + std::to_string(o.holdSteps));
  }
  NV_CHECK(c.threads >= 0 && c.threads <= 1024, "threads must be in 0..1024");
  NV_CHECK(c.quantizationAwareFraction >= 0.0 && c.quantizationAwareFraction <= 1.0,
    "the quantisation-aware fraction of the steps must be in [0, 1], got " +
      std::to_string(c.quantizationAwareFraction));
  NV_CHECK(c.importanceGrid == 0 || (c.importanceGrid >= 2 && c.importanceGrid <= 64),
    "importance grid must be 0 (off) or 2..64 cells per axis, got " + std::to_string(c.importanceGrid));
}

} // namespace nv
