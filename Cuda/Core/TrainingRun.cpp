#include "TrainingRun.h"

#include "Error.h"
#include "ThreadPriority.h"

#include <algorithm>
#include <system_error>
#include <utility>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace nv
{
namespace
{
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t)
{
  return std::chrono::duration<double>(Clock::now() - t).count();
}
} // namespace

const char* runStateName(RunState s)
{
  switch (s)
  {
    case RunState::Starting:
      return "Starting";
    case RunState::Running:
      return "Training";
    case RunState::Paused:
      return "Paused";
    case RunState::Finishing:
      return "Finishing";
    case RunState::Finished:
      return "Finished";
    case RunState::Stopped:
      return "Stopped";
    case RunState::Failed:
      return "Failed";
  }
  return "Unknown";
}

bool isSettled(RunState s)
{
  return s == RunState::Finished || s == RunState::Stopped || s == RunState::Failed;
}

TrainingRun::TrainingRun(std::shared_ptr<NetworkSession> session, std::shared_ptr<TrainingData> data,
  const TrainConfig& config, const RunLimits& limits, PhaseEndHook onPhaseEnd)
  : SessionPtr(std::move(session))
  , DataPtr(std::move(data))
  , Config(config)
  , Limits(limits)
  , OnPhaseEnd(std::move(onPhaseEnd))
{
  NV_CHECK(this->SessionPtr && this->DataPtr, "TrainingRun: no session or data");
  this->Current.Steps = std::max<int64_t>(limits.FirstStep, 0);
  this->Current.TargetSteps = std::max<int64_t>(limits.MaxSteps, this->Current.Steps);
  this->PhaseBudget = limits.TimeBudget;
  this->PhaseTargetPsnr = limits.TargetPsnr;
  this->ScheduleStart = this->Current.Steps;
  this->RequestedBatch = config.batchSize;
  if (limits.TimeBudget > 0.0 && !config.deterministic && config.batchSize > kCalibrationBatch)
  {
    this->Config.batchSize = kCalibrationBatch; // one step to measure first (budgetedBatch)
    this->Calibrating = true;
  }
}

TrainingRun::~TrainingRun()
{
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->StopRequested = true;
    this->Quit = true;
  }
  this->Changed.notify_all();
  if (this->Thread.joinable())
  {
    this->Thread.join();
  }
}

std::unique_ptr<nv::Trainer> TrainingRun::createTrainer()
{
  if (this->Prologue)
  {
    const Clock::time_point started = Clock::now();
    std::function<void()> prologue = std::move(this->Prologue);
    this->Prologue = nullptr;
    prologue();
    std::lock_guard<std::mutex> lock(this->Mutex);
    if (this->PhaseBudget > 0.0)
      this->PhaseBudget = std::max(1e-3, this->PhaseBudget - secondsSince(started));
  }
  const TrainingData& d = *this->DataPtr;
  if (d.BankValues.empty())
    return this->SessionPtr->createTrainer(d.Field.View, this->Config);
  TrainingPoints bank;
  bank.xyz = d.BankXyz.data();
  bank.values = d.BankValues.data();
  bank.count = static_cast<int64_t>(d.BankValues.size());
  return this->SessionPtr->createTrainer(bank, this->Config);
}

void TrainingRun::runHere(const std::function<bool()>& abort, const std::function<void(double)>& progress)
{
  this->Background = false;
  try
  {
    this->Trainer = this->createTrainer();
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->Current.DeviceMemoryBytes = this->Trainer->deviceMemoryBytes();
    this->Current.State = RunState::Running;
  }
  catch (const std::exception& e)
  {
    this->fail(e.what());
    return;
  }
  this->runPhase(abort, progress);
}

void TrainingRun::startInBackground()
{
  this->Background = true;
  try
  {
    this->Thread = std::thread([this]() { this->worker(); });
  }
  catch (const std::system_error& e) // a process limit: say so instead of an unexplained failure
  {
    this->Background = false;
    NV_THROW(std::string("cannot start the training thread (") + e.what() + "); lower Threads or raise the process's "
      "limits (ulimit -u, ulimit -v)");
  }
}

void TrainingRun::worker()
{
  if (this->Config.lowPriority)
    lowerCurrentThreadPriority(); // this thread is also the CPU trainer's worker 0
  try
  {
    auto trainer = this->createTrainer();
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->Trainer = std::move(trainer);
    this->Current.DeviceMemoryBytes = this->Trainer->deviceMemoryBytes();
    if (this->Current.State == RunState::Starting)
    {
      this->Current.State = this->PauseRequested ? RunState::Paused : RunState::Running;
    }
    ++this->Current.Serial;
  }
  catch (const std::exception& e)
  {
    this->fail(e.what());
    return;
  }
  for (;;)
  {
    this->runPhase(nullptr, nullptr);
    std::unique_lock<std::mutex> lock(this->Mutex);
    this->Changed.wait(lock, [this]() { return this->Quit || this->PhaseRequested; });
    if (this->Quit)
    {
      return;
    }
    this->PhaseRequested = false;
  }
}

void TrainingRun::fail(const std::string& message)
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->Current.State = RunState::Failed;
  this->Current.Error = message;
  ++this->Current.Serial;
  this->Changed.notify_all();
}

void TrainingRun::publish()
{
  this->Trainer->publish();
  std::lock_guard<std::mutex> lock(this->Mutex);
  ++this->Current.Serial;
}

void TrainingRun::runPhase(const std::function<bool()>& abort, const std::function<void(double)>& progress)
{
  const bool gpu = this->Trainer->device() == Device::Cuda;
  // Chunks of steps queued back to back (one loss read-back each): ~20 ms on a GPU, one step on the CPU.
  const int64_t chunkMax = gpu ? 64 : 1;
  std::vector<float> losses(static_cast<size_t>(chunkMax));
  auto lastPublish = Clock::now();
  const int64_t phaseFirstStep = this->status().Steps;
  double lastProgress = -1.0;
  // The run's clock: wall time while not paused. activeBase: seconds up to activeSince.
  double activeBase = this->status().Seconds;
  auto activeSince = Clock::now();
  std::string reason;
  try
  {
    for (;;)
    {
      int64_t step = 0, count = 0;
      double phaseSeconds = 0.0;
      bool fast = false;
      {
        std::unique_lock<std::mutex> lock(this->Mutex);
        if (abort && abort())
        {
          this->StopRequested = true;
        }
        if (this->PauseRequested && !this->StopRequested && this->Background)
        {
          this->Current.State = RunState::Paused;
          ++this->Current.Serial;
          activeBase += secondsSince(activeSince); // paused time does not count
          this->Current.Seconds = activeBase;
          this->Changed.notify_all();
          this->Changed.wait(lock, [this]() { return !this->PauseRequested || this->StopRequested; });
          activeSince = Clock::now();
          if (!this->StopRequested)
          {
            this->Current.State = RunState::Running;
            ++this->Current.Serial;
          }
        }
        if (this->StopRequested)
        {
          reason = "stopped";
          break;
        }
        step = this->Current.Steps + 1;
        phaseSeconds = activeBase + secondsSince(activeSince) - this->PhaseStartSeconds;
        // The budget's end: what the phase end will take to measure the network is kept out of it.
        const double budgetLeft = this->PhaseBudget - phaseSeconds - this->finalReserveSeconds();
        if (step > this->Current.TargetSteps)
        {
          reason = "step limit";
          break;
        }
        if (this->PhaseBudget > 0.0 && budgetLeft <= 0.0)
        {
          reason = "time budget";
          break;
        }
        count = std::min(chunkMax, this->Current.TargetSteps - step + 1);
        if (this->PhaseBudget > 0.0 && this->StepSeconds > 0.0)
        {
          // The budget holds: training goes on until it is spent, but no step starts that would end more than
          // kBudgetOverrun past it (measured by the last step); a chunk ends within that.
          const double left = budgetLeft + kBudgetOverrun * this->PhaseBudget;
          if (left < this->StepSeconds)
          {
            reason = "time budget";
            break;
          }
          count = std::max<int64_t>(1, std::min<int64_t>(count, static_cast<int64_t>(left / this->StepSeconds)));
        }
        if (this->Calibrating)
        {
          count = 1;
        }
        if (this->DataPtr->Probe && this->Limits.PsnrInterval > 0)
        {
          count = std::min<int64_t>(count, this->Limits.PsnrInterval - (step - 1) % this->Limits.PsnrInterval);
        }
        fast = this->FastForward;
      }

      if (this->GoodStep < 0)
      {
        this->snapshot(std::numeric_limits<double>::quiet_NaN()); // the starting network: the first rollback point
      }
      if (this->PhaseBudget > 0.0 && this->Limits.FinalSamples > 0 && this->InferSecondsPerSample <= 0.0 &&
        this->GoodStep >= 0 && this->Current.Steps > phaseFirstStep)
      {
        this->measureInference();
      }
      this->planSchedule(phaseSeconds);
      const auto before = Clock::now();
      this->Trainer->steps(count, losses.data());
      const double took = secondsSince(before);
      this->StepSeconds = took / static_cast<double>(count);
      // Diverged: a loss that is not finite, or above kDivergedLoss (the targets are normalised to [0, 1]: such a
      // loss means outputs tens of ranges away, a network blowing up on its way to Inf).
      int64_t bad = -1;
      for (int64_t k = 0; k < count && bad < 0; ++k)
      {
        const float l = losses[static_cast<size_t>(k)];
        bad = std::isfinite(l) && l <= kDivergedLoss ? -1 : k;
      }
      if (bad >= 0)
      {
        if (!this->rollBack(step + bad, losses[static_cast<size_t>(bad)]))
        {
          std::ostringstream s;
          s << "training diverged (loss " << losses[static_cast<size_t>(bad)] << " at step " << step + bad << ") " << this->Rollbacks
            << " times; the learning rate is now " << this->Config.optimizer.learningRate
            << ". Check the input's range or lower LearningRate.";
          throw Error(s.str());
        }
        continue;
      }

      bool probeNow = false;
      {
        std::lock_guard<std::mutex> lock(this->Mutex);
        if (this->StopRequested)
        {
          reason = "stopped"; // the chunk in flight is not published
          break;
        }
        const double start = this->Current.Seconds;
        const double elapsed = std::max(0.0, activeBase + secondsSince(activeSince) - start);
        for (int64_t k = 0; k < count; ++k)
        {
          LogRow row;
          row.Step = step + k;
          row.LearningRate = this->Config.optimizer.learningRateAt(row.Step - this->ScheduleStart);
          row.Loss = losses[static_cast<size_t>(k)];
          row.ElapsedSeconds = start + elapsed * static_cast<double>(k + 1) / static_cast<double>(count);
          row.PSNR = std::numeric_limits<double>::quiet_NaN();
          this->Rows.push_back(row);
        }
        this->Current.Steps = step + count - 1;
        this->Current.Seconds = start + elapsed;
        this->Current.Loss = losses[static_cast<size_t>(count - 1)];
        ++this->Current.Serial;
        probeNow = this->DataPtr->Probe && this->Limits.PsnrInterval > 0 &&
          this->Current.Steps % this->Limits.PsnrInterval == 0 &&
          this->Current.Steps < this->Current.TargetSteps;
      }

      if (probeNow)
      {
        this->publish();
        lastPublish = Clock::now();
        const double psnr = this->DataPtr->Probe->estimate(*this->SessionPtr);
        if (this->snapshotDue(true, this->Limits.KeepBest && std::isfinite(psnr) && psnr > this->BestPsnr))
        {
          this->snapshot(psnr);
        }
        std::lock_guard<std::mutex> lock(this->Mutex);
        this->Rows.back().PSNR = psnr;
        this->Current.Psnr = psnr;
        if (this->PhaseTargetPsnr > 0.0 && psnr >= this->PhaseTargetPsnr)
        {
          reason = "target PSNR";
          break;
        }
      }
      else if (!(this->DataPtr->Probe && this->Limits.PsnrInterval > 0) && this->snapshotDue(false, false))
      {
        this->snapshot(std::numeric_limits<double>::quiet_NaN());
      }
      else if (this->Background && !fast && secondsSince(lastPublish) >= this->Limits.PublishSeconds)
      {
        this->publish();
        lastPublish = Clock::now();
      }

      if (this->PhaseBudget > 0.0 && !this->Config.deterministic)
      {
        const int batch = this->budgetedBatch(this->StepSeconds, this->Config.batchSize);
        if (batch != this->Config.batchSize || this->Calibrating)
        {
          this->resizeBatch(batch, this->StepSeconds);
          lastPublish = Clock::now();
        }
      }

      if (progress)
      {
        const RunStatus s = this->status();
        const double span = static_cast<double>(std::max<int64_t>(s.TargetSteps - phaseFirstStep, 1));
        double fraction = static_cast<double>(s.Steps - phaseFirstStep) / span;
        if (this->PhaseBudget > 0.0)
        {
          fraction = std::max(fraction, (s.Seconds - this->PhaseStartSeconds) / this->PhaseBudget);
        }
        fraction = std::min(fraction, 1.0);
        if (fraction - lastProgress >= 0.01)
        {
          progress(fraction);
          lastProgress = fraction;
        }
      }
    }
    // Background: nothing is published after stop(). In the calling thread an abort comes between chunks, and the
    // steps done are kept.
    if (reason != "stopped" || !this->Background)
    {
      this->publish();
      if (reason != "stopped")
        this->keepBestNetwork();
    }
    this->endPhase(reason);
  }
  catch (const std::exception& e)
  {
    this->fail(e.what());
  }
}

bool TrainingRun::snapshotDue(bool probe, bool improved) const
{
  if (this->Config.deterministic)
    return probe || this->Current.Steps - this->GoodStep >= kSnapshotSteps;
  const double since = secondsSince(this->LastSnapshot);
  return since >= 20.0 * this->SnapshotCost && (improved || since >= kSnapshotSeconds);
}

void TrainingRun::snapshot(double probePsnr)
{
  if (this->Candidate.paramCount() == 0)
    this->Candidate = this->SessionPtr->currentModel(); // once: the buffer the snapshots are copied into
  const auto t0 = Clock::now();
  this->Trainer->syncTo(this->Candidate);
  this->LastSnapshot = Clock::now();
  this->SnapshotCost = secondsSince(t0);
  for (float p : this->Candidate.params())
    if (!std::isfinite(p))
      return; // a network on its way to diverging: not a rollback point
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->GoodStep = this->Current.Steps;
  this->GoodRows = this->Rows.size();
  if (this->Limits.KeepBest && std::isfinite(probePsnr) && probePsnr > this->BestPsnr)
  {
    this->Best = this->Candidate;
    this->BestPsnr = probePsnr;
    this->BestStep = this->Current.Steps;
  }
  std::swap(this->Good, this->Candidate); // the old rollback point's buffer takes the next snapshot
}

bool TrainingRun::rollBack(int64_t failedStep, double loss)
{
  if (this->Rollbacks >= kMaxRollbacks || this->GoodStep < 0)
    return false;
  ++this->Rollbacks;
  this->Config.optimizer.learningRate *= 0.1;
  this->SessionPtr->setModel(this->Good);
  auto trainer = this->createTrainer(); // from the session's network, with a fresh optimizer state
  std::ostringstream s;
  s << "training diverged at step " << failedStep << " (loss " << loss << "): rolled back to the network of step "
    << this->GoodStep << " and lowered the learning rate to " << this->Config.optimizer.learningRate;
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->Trainer = std::move(trainer);
  this->Rows.resize(this->GoodRows);
  this->Current.Steps = this->GoodStep;
  this->ScheduleStart = this->GoodStep;
  this->Current.Warnings.push_back(s.str());
  ++this->Current.Serial;
  return true;
}

void TrainingRun::keepBestNetwork()
{
  if (!this->Limits.KeepBest || !this->DataPtr->Probe || this->BestStep < 0)
    return;
  const double last = this->DataPtr->Probe->estimate(*this->SessionPtr);
  // 0.1 dB: the probes' own noise; a better last network (or a NaN one) is never replaced by a worse best.
  if (std::isfinite(last) && !(this->BestPsnr > last + 0.1))
    return;
  this->SessionPtr->setModel(this->Best);
  std::ostringstream s;
  s.precision(4);
  s << "kept the network of step " << this->BestStep << " (PSNR estimate " << this->BestPsnr
    << " dB) over the last one (" << last << " dB)";
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->Current.Psnr = this->BestPsnr;
  this->Current.Notes.push_back(s.str());
  ++this->Current.Serial;
}

void TrainingRun::endPhase(const std::string& reason)
{
  RunStatus status;
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->Current.EndReason = reason;
    this->Current.State = RunState::Finishing;
    this->FastForward = false;
    ++this->Current.Serial;
    status = this->Current;
  }
  this->Changed.notify_all();
  if (this->OnPhaseEnd)
  {
    this->OnPhaseEnd(*this, status); // exceptions: fail() by the caller
  }
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->Current.State = reason == "stopped" ? RunState::Stopped : RunState::Finished;
  this->StopRequested = false;
  this->PauseRequested = false;
  ++this->Current.Serial;
  this->Changed.notify_all();
}

void TrainingRun::pause()
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->PauseRequested = true;
  if (this->Background && this->Current.State == RunState::Running)
  {
    // Shown at once; the chunk in flight (one step on the CPU, <= 64 on a GPU) still completes.
    this->Current.State = RunState::Paused;
    ++this->Current.Serial;
  }
}

void TrainingRun::resume()
{
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->PauseRequested = false;
    if (this->Current.State == RunState::Paused)
    {
      this->Current.State = RunState::Running;
      ++this->Current.Serial;
    }
  }
  this->Changed.notify_all();
}

void TrainingRun::extend(int64_t steps, bool fastForward)
{
  if (steps <= 0)
  {
    return;
  }
  bool runHere = false;
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    const RunState s = this->Current.State;
    if (s == RunState::Failed)
    {
      return;
    }
    this->FastForward = fastForward;
    this->PauseRequested = false;
    if (s == RunState::Finished || s == RunState::Stopped)
    {
      // A new phase from the trainer's state: exactly `steps` more, no time budget, no PSNR target.
      this->Current.TargetSteps = this->Current.Steps + steps;
      this->PlanOpen = false;
      this->PhaseBudget = 0.0;
      this->PhaseTargetPsnr = 0.0;
      this->PhaseStartSeconds = this->Current.Seconds;
      this->StopRequested = false;
      this->Current.State = RunState::Running;
      this->PhaseRequested = this->Background;
      runHere = !this->Background;
    }
    else
    {
      this->Current.TargetSteps += steps;
    }
    ++this->Current.Serial;
  }
  this->Changed.notify_all();
  if (runHere)
  {
    this->runPhase(nullptr, nullptr);
  }
}

void TrainingRun::stop()
{
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->StopRequested = true;
    const RunState s = this->Current.State;
    if (this->Background && (s == RunState::Running || s == RunState::Paused || s == RunState::Starting))
    {
      // Shown at once: nothing is published any more; the phase-end hook measures the network next.
      this->Current.State = RunState::Finishing;
      this->Current.EndReason = "stopped";
    }
    ++this->Current.Serial;
  }
  this->Changed.notify_all();
}

bool TrainingRun::wait(double timeoutSeconds)
{
  std::unique_lock<std::mutex> lock(this->Mutex);
  auto settled = [this]() { return isSettled(this->Current.State); };
  if (timeoutSeconds < 0.0)
  {
    this->Changed.wait(lock, settled);
    return true;
  }
  return this->Changed.wait_for(lock, std::chrono::duration<double>(timeoutSeconds), settled);
}

RunStatus TrainingRun::status() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->Current;
}

std::vector<LogRow> TrainingRun::log() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->Rows;
}

} // namespace nv
