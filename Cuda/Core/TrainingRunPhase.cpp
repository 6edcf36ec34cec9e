// NeuralVolume engine: the phase loop of a training run (TrainingRun::runPhase): chunks of steps until the phase's
// step limit, time budget or target PSNR, or a stop; each chunk is planned, trained (rolled back when it diverges),
// logged, then probed or published, and the batch is fitted to the budget. See TrainingRun.h.
#include "TrainingRun.h"

#include "Error.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace nv
{
namespace
{
using Clock = std::chrono::steady_clock;

/// The first step of a chunk whose loss diverged (not finite, or above `limit`: the targets are normalised to
/// [0, 1], so such a loss means outputs tens of ranges away, a network blowing up on its way to Inf); -1 if none.
int64_t firstDivergedStep(const std::vector<float>& losses, int64_t count, double limit)
{
  int64_t bad = -1;
  for (int64_t k = 0; k < count && bad < 0; ++k)
  {
    const float l = losses[static_cast<size_t>(k)];
    bad = std::isfinite(l) && l <= limit ? -1 : k;
  }
  return bad;
}
} // namespace

/// The state of one phase's loop, and the chunk of steps at hand.
struct TrainingRun::PhaseLoop
{
  PhaseLoop(bool gpu, const RunStatus& start)
    : chunkMax(gpu ? 64 : 1)
    , losses(static_cast<size_t>(chunkMax))
    , lastPublish(Clock::now())
    , phaseFirstStep(start.Steps)
    , activeBase(start.Seconds)
    , activeSince(Clock::now())
  {
  }
  /// The run's clock: wall time while not paused.
  double activeSeconds() const { return this->activeBase + secondsSince(this->activeSince); }

  /// Chunks of steps queued back to back (one loss read-back each): ~20 ms on a GPU, one step on the CPU.
  const int64_t chunkMax;
  std::vector<float> losses;
  Clock::time_point lastPublish;
  const int64_t phaseFirstStep;
  double lastProgress = -1.0;
  double activeBase; ///< seconds of the run's clock up to activeSince
  Clock::time_point activeSince;
  std::string reason; ///< why the phase ended

  // The chunk: its first step, its length, the phase's seconds when it was planned, fast-forward.
  int64_t step = 0;
  int64_t count = 0;
  double phaseSeconds = 0.0;
  bool fast = false;
};

void TrainingRun::runPhase(const std::function<bool()>& abort, const std::function<void(double)>& progress)
{
  PhaseLoop loop(this->Trainer->device() == Device::Cuda, this->status());
  try
  {
    for (;;)
    {
      if (!this->planChunk(loop, abort))
        break;
      if (!this->trainChunk(loop))
        continue; // diverged: back at the last good snapshot with a lower learning rate
      bool probeNow = false;
      if (!this->logChunk(loop, probeNow))
        break;
      if (!this->probeOrPublish(loop, probeNow))
        break;
      this->fitBatchToBudget(loop);
      this->reportProgress(loop, progress);
    }
    // Background: nothing is published after stop(). In the calling thread an abort comes between chunks, and the
    // steps done are kept.
    if (loop.reason != "stopped" || !this->Background)
    {
      this->publish();
      if (loop.reason != "stopped")
        this->keepBestNetwork();
    }
    this->endPhase(loop.reason);
  }
  catch (const std::exception& e)
  {
    this->fail(e.what());
  }
}

void TrainingRun::waitWhilePaused(std::unique_lock<std::mutex>& lock, PhaseLoop& loop)
{
  this->Current.State = RunState::Paused;
  ++this->Current.Serial;
  loop.activeBase += secondsSince(loop.activeSince); // paused time does not count
  this->Current.Seconds = loop.activeBase;
  this->Changed.notify_all();
  this->Changed.wait(lock, [this]() { return !this->PauseRequested || this->StopRequested; });
  loop.activeSince = Clock::now();
  if (!this->StopRequested)
  {
    this->Current.State = RunState::Running;
    ++this->Current.Serial;
  }
}

bool TrainingRun::planChunk(PhaseLoop& loop, const std::function<bool()>& abort)
{
  std::unique_lock<std::mutex> lock(this->Mutex);
  if (abort && abort())
  {
    this->StopRequested = true;
  }
  if (this->PauseRequested && !this->StopRequested && this->Background)
  {
    this->waitWhilePaused(lock, loop);
  }
  if (this->StopRequested)
  {
    loop.reason = "stopped";
    return false;
  }
  loop.step = this->Current.Steps + 1;
  loop.phaseSeconds = loop.activeSeconds() - this->PhaseStartSeconds;
  // The budget's end: what the phase end will take to measure the network is kept out of it.
  const double budgetLeft = this->PhaseBudget - loop.phaseSeconds - this->finalReserveSeconds();
  if (loop.step > this->Current.TargetSteps)
  {
    loop.reason = "step limit";
    return false;
  }
  if (this->PhaseBudget > 0.0 && budgetLeft <= 0.0)
  {
    loop.reason = "time budget";
    return false;
  }
  loop.count = std::min(loop.chunkMax, this->Current.TargetSteps - loop.step + 1);
  if (this->PhaseBudget > 0.0 && this->StepSeconds > 0.0)
  {
    // The budget holds: training goes on until it is spent, but no step starts that would end more than
    // kBudgetOverrun past it (measured by the last step); a chunk ends within that.
    const double left = budgetLeft + kBudgetOverrun * this->PhaseBudget;
    if (left < this->StepSeconds)
    {
      loop.reason = "time budget";
      return false;
    }
    loop.count =
      std::max<int64_t>(1, std::min<int64_t>(loop.count, static_cast<int64_t>(left / this->StepSeconds)));
  }
  if (this->Calibrating)
  {
    loop.count = 1;
  }
  if (this->DataPtr->Probe && this->Limits.PsnrInterval > 0)
  {
    loop.count =
      std::min<int64_t>(loop.count, this->Limits.PsnrInterval - (loop.step - 1) % this->Limits.PsnrInterval);
  }
  loop.fast = this->FastForward;
  return true;
}

bool TrainingRun::trainChunk(PhaseLoop& loop)
{
  if (this->GoodStep < 0)
  {
    this->snapshot(std::numeric_limits<double>::quiet_NaN()); // the starting network: the first rollback point
  }
  if (this->PhaseBudget > 0.0 && this->Limits.FinalSamples > 0 && this->InferSecondsPerSample <= 0.0 &&
    this->GoodStep >= 0 && this->Current.Steps > loop.phaseFirstStep)
  {
    this->measureInference();
  }
  this->planSchedule(loop.phaseSeconds);
  const auto before = Clock::now();
  this->Trainer->steps(loop.count, loop.losses.data());
  const double took = secondsSince(before);
  this->StepSeconds = took / static_cast<double>(loop.count);
  const int64_t bad = firstDivergedStep(loop.losses, loop.count, kDivergedLoss);
  if (bad < 0)
  {
    return true;
  }
  const float badLoss = loop.losses[static_cast<size_t>(bad)];
  if (!this->rollBack(loop.step + bad, badLoss))
  {
    std::ostringstream s;
    s << "training diverged (loss " << badLoss << " at step " << loop.step + bad << ") " << this->Rollbacks
      << " times; the learning rate is now " << this->Config.optimizer.learningRate
      << ". Check the input's range or lower LearningRate.";
    throw Error(s.str());
  }
  return false;
}

bool TrainingRun::logChunk(PhaseLoop& loop, bool& probeNow)
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (this->StopRequested)
  {
    loop.reason = "stopped"; // the chunk in flight is not published
    return false;
  }
  const double start = this->Current.Seconds;
  const double elapsed = std::max(0.0, loop.activeSeconds() - start);
  for (int64_t k = 0; k < loop.count; ++k)
  {
    LogRow row;
    row.Step = loop.step + k;
    row.LearningRate = this->Config.optimizer.learningRateAt(row.Step - this->ScheduleStart);
    row.Loss = loop.losses[static_cast<size_t>(k)];
    row.ElapsedSeconds = start + elapsed * static_cast<double>(k + 1) / static_cast<double>(loop.count);
    row.PSNR = std::numeric_limits<double>::quiet_NaN();
    this->Log.append(row, k + 1 == loop.count);
  }
  this->Current.Steps = loop.step + loop.count - 1;
  this->Current.Seconds = start + elapsed;
  this->Current.Loss = loop.losses[static_cast<size_t>(loop.count - 1)];
  ++this->Current.Serial;
  probeNow = this->DataPtr->Probe && this->Limits.PsnrInterval > 0 &&
    this->Current.Steps % this->Limits.PsnrInterval == 0 && this->Current.Steps < this->Current.TargetSteps;
  return true;
}

bool TrainingRun::probeOrPublish(PhaseLoop& loop, bool probeNow)
{
  if (probeNow)
  {
    this->publish();
    loop.lastPublish = Clock::now();
    const double psnr = this->DataPtr->Probe->estimate(*this->SessionPtr);
    if (this->snapshotDue(true, this->Limits.KeepBest && std::isfinite(psnr) && psnr > this->BestPsnr))
    {
      this->snapshot(psnr);
    }
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->Log.setLastPsnr(psnr);
    this->Current.Psnr = psnr;
    if (this->PhaseTargetPsnr > 0.0 && psnr >= this->PhaseTargetPsnr)
    {
      loop.reason = "target PSNR";
      return false;
    }
  }
  else if (!(this->DataPtr->Probe && this->Limits.PsnrInterval > 0) && this->snapshotDue(false, false))
  {
    this->snapshot(std::numeric_limits<double>::quiet_NaN());
  }
  else if (this->Background && !loop.fast && secondsSince(loop.lastPublish) >= this->Limits.PublishSeconds)
  {
    this->publish();
    loop.lastPublish = Clock::now();
  }
  return true;
}

void TrainingRun::fitBatchToBudget(PhaseLoop& loop)
{
  if (this->PhaseBudget > 0.0 && !this->Config.deterministic)
  {
    const int batch = this->budgetedBatch(this->StepSeconds, this->Config.batchSize);
    if (batch != this->Config.batchSize || this->Calibrating)
    {
      this->resizeBatch(batch, this->StepSeconds);
      loop.lastPublish = Clock::now();
    }
  }
}

void TrainingRun::reportProgress(PhaseLoop& loop, const std::function<void(double)>& progress)
{
  if (!progress)
  {
    return;
  }
  const RunStatus s = this->status();
  const double span = static_cast<double>(std::max<int64_t>(s.TargetSteps - loop.phaseFirstStep, 1));
  double fraction = static_cast<double>(s.Steps - loop.phaseFirstStep) / span;
  if (this->PhaseBudget > 0.0)
  {
    fraction = std::max(fraction, (s.Seconds - this->PhaseStartSeconds) / this->PhaseBudget);
  }
  fraction = std::min(fraction, 1.0);
  if (fraction - loop.lastProgress >= 0.01)
  {
    progress(fraction);
    loop.lastProgress = fraction;
  }
}

} // namespace nv
