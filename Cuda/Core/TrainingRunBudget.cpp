// NeuralVolume engine: a training run's time budget and plan: the cap of its batch (budgetedBatch, resizeBatch) and the planned
// steps of its annealed learning-rate schedule (planSchedule); see TrainingRun.h.
#include "TrainingRun.h"

#include "Engine.h"

#include <algorithm>
#include <chrono>
#include <vector>
#include <cmath>
#include <mutex>
#include <sstream>

namespace nv
{

int TrainingRun::budgetedBatch(double stepSeconds, int batch) const
{
  if (stepSeconds <= 0.0 || batch <= 0)
    return batch;
  const double share = stepSeconds / this->PhaseBudget;
  if (!this->Calibrating && share <= 2.0 * kStepShare)
    return batch;
  // Seconds per sample of this step: an upper bound for a larger batch (the fixed cost of a step is shared by more
  // samples), so the cap errs on the safe side.
  const double perSample = stepSeconds / static_cast<double>(batch);
  const double fits = std::floor(kStepShare * this->PhaseBudget / perSample);
  const double floor = std::min(kCalibrationBatch, this->RequestedBatch);
  return static_cast<int>(std::max(floor, std::min(fits, static_cast<double>(this->RequestedBatch))));
}

void TrainingRun::resizeBatch(int batch, double stepSeconds)
{
  this->Calibrating = false;
  const int previous = this->Config.batchSize;
  std::unique_ptr<nv::Trainer> trainer;
  if (batch != previous) // else the calibration batch is the one to keep
  {
    this->publish(); // the new trainer starts from the network trained so far
    this->Trainer.reset();
    this->Config.batchSize = batch;
    this->StepSeconds = stepSeconds * static_cast<double>(batch) / static_cast<double>(previous); // until measured
    trainer = this->createTrainer();
  }
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (trainer)
  {
    this->Trainer = std::move(trainer);
    this->ScheduleStart = this->Current.Steps;
    this->Current.DeviceMemoryBytes = this->Trainer->deviceMemoryBytes();
  }
  if (batch < this->RequestedBatch)
  {
    std::ostringstream s;
    s.precision(3);
    s << "BatchSize " << this->RequestedBatch << " capped to " << batch << " so that one step ("
      << "measured: " << stepSeconds << " s for " << previous << " samples) stays within "
      << static_cast<int>(kStepShare * 100.0) << "% of the " << this->PhaseBudget << " s TimeBudget";
    if (this->Current.Warnings.empty() || this->Current.Warnings.back().compare(0, 9, "BatchSize") != 0)
      this->Current.Warnings.push_back(s.str());
  }
  ++this->Current.Serial;
}

void TrainingRun::measureInference()
{
  // What the phase end does per sample, on a grid of up to 2^17 samples: the network decoded to doubles in host
  // memory, then compared with a field (compareToSource; a decode for the output costs less). Enough samples that
  // the calls' fixed costs are shared, at most what the phase end evaluates.
  const int64_t count = std::min<int64_t>(this->Limits.FinalSamples, int64_t(1) << 17);
  const int64_t nx = std::min<int64_t>(count, 64), ny = std::max<int64_t>(1, std::min<int64_t>(count / nx, 64));
  const int64_t nz = std::max<int64_t>(1, count / (nx * ny));
  std::vector<double> decoded(static_cast<size_t>(nx * ny * nz));
  std::vector<float> field(decoded.size(), 0.5f);
  VolumeView view;
  view.data = field.data();
  view.type = ScalarType::Float32;
  view.dims[0] = nx;
  view.dims[1] = ny;
  view.dims[2] = nz;
  // Twice: the first call may also build the evaluator of a new network; the faster one is the rate (a busy machine
  // only slows a measurement).
  double best = 0.0;
  for (int attempt = 0; attempt < 2; ++attempt)
  {
    const auto start = std::chrono::steady_clock::now();
    decodeGridValues(*this->SessionPtr, nx, ny, nz, 0, nz, decoded.data());
    compareDecoded(decoded.data(), view, 0.0, 1.0, 0);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    best = attempt == 0 ? seconds : std::min(best, seconds);
  }
  this->InferSecondsPerSample = std::max(best, 1e-9) / static_cast<double>(decoded.size());
}

double TrainingRun::finalReserveSeconds() const
{
  if (this->Limits.FinalSamples <= 0 || this->PhaseBudget <= 0.0)
    return 0.0;
  double perSample = this->InferSecondsPerSample;
  if (perSample <= 0.0 && this->StepSeconds > 0.0 && this->Config.batchSize > 0)
  {
    // No probe yet: a training step's forward pass is about a third of it.
    perSample = this->StepSeconds / (3.0 * static_cast<double>(this->Config.batchSize));
  }
  // At most half the budget: a measurement estimated longer than that still leaves training its half.
  return std::min(static_cast<double>(this->Limits.FinalSamples) * perSample, kMaxReserveShare * this->PhaseBudget);
}

void TrainingRun::planSchedule(double phaseSeconds)
{
  OptimizerConfig& o = this->Config.optimizer;
  if (!this->PlanOpen || o.schedule == LearningRateSchedule::StepDecay)
    return;
  const double done = static_cast<double>(this->Current.Steps - this->ScheduleStart);
  double planned = static_cast<double>(this->Current.TargetSteps - this->ScheduleStart);
  // The phase's mean time per step so far (the last chunk's while none is done): one slow chunk on a busy machine
  // does not pull the planned end, and with it the rate, down early.
  const double perStep = done >= 1.0 && phaseSeconds > 0.0 ? phaseSeconds / done : this->StepSeconds;
  if (this->PhaseBudget > 0.0 && perStep > 0.0 && !this->Config.deterministic)
    planned = std::min(planned,
      done + std::max(0.0, this->PhaseBudget - phaseSeconds - this->finalReserveSeconds()) / perStep);
  planned = std::max(planned, done + 1.0);
  if (planned == o.plannedSteps)
    return;
  this->Trainer->setPlannedSteps(planned);
  std::lock_guard<std::mutex> lock(this->Mutex);
  o.plannedSteps = planned; // the log's learning rates
}

} // namespace nv
