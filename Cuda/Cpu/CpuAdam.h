// NeuralVolume engine: Adam on the CPU (PyTorch's formulation; the gradient is consumed and zeroed).
#pragma once

#include "Core/Config.h"

#include <cstdint>
#include <vector>

namespace nv
{

class ThreadPool;

class CpuAdam
{
public:
  CpuAdam(const OptimizerConfig& config, size_t paramCount);

  /// One update of params[0..n) with grad (zeroed afterwards); `step` is 1-based; the schedule's rate times
  /// rateScale (PlateauSchedule).
  void update(float* params, float* grad, int64_t step, ThreadPool& pool, double rateScale = 1.0);
  /// OptimizerConfig::plannedSteps of the schedule (Trainer::setPlannedSteps).
  void setPlannedSteps(double steps) { Config.plannedSteps = steps; }

  /// The arithmetic of one element, shared with the tests' closed form.
  static void updateRange(float* p, float* g, float* m, float* v, size_t begin, size_t end, float lr, float beta1,
    float beta2, float eps, double bc1, double bc2);

private:
  OptimizerConfig Config;
  std::vector<float> FirstMoment;
  std::vector<float> SecondMoment;
};

} // namespace nv
