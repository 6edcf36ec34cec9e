// NeuralVolume engine: learning-rate decay driven by the training loss (OptimizerConfig::plateauWindow).
// Host code shared by both trainers. The loss of every step is averaged over windows of `plateauWindow` steps; a
// window whose mean loss is not at least 1% below the best window's halves the rate (down to 1/64 of the schedule's).
// The decision depends on the losses only, so a deterministic run stays deterministic.
#pragma once

#include "Config.h"

#include <cmath>
#include <cstdint>

namespace nv
{

class PlateauSchedule
{
public:
  explicit PlateauSchedule(const OptimizerConfig& config)
    : Window(config.plateauWindow)
  {
  }

  /// Factor on the schedule's rate (OptimizerConfig::learningRateAt) for the next step.
  double scale() const { return Scale; }

  /// The loss of the step just taken (non-finite losses are left to the caller's divergence handling).
  void observe(float loss)
  {
    if (Window <= 0 || !std::isfinite(loss))
      return;
    Sum += loss;
    if (++Count < Window)
      return;
    const double mean = Sum / Count;
    Sum = 0.0;
    Count = 0;
    if (mean < Best * (1.0 - kImprovement))
      Best = mean;
    else if (Scale > kMinScale)
      Scale *= 0.5;
  }

private:
  static constexpr double kImprovement = 0.01;
  static constexpr double kMinScale = 1.0 / 64.0;
  int Window = 0;
  double Sum = 0.0;
  int Count = 0;
  double Best = INFINITY;
  double Scale = 1.0;
};

} // namespace nv
