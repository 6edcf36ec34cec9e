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
} // namespace

double TrainingRun::secondsSince(std::chrono::steady_clock::time_point t)
{
  return std::chrono::duration<double>(Clock::now() - t).count();
}

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
      this->PhaseBudget =
        std::max(1e-3, this->PhaseBudget - std::max(0.0, secondsSince(started) - this->PrologueExcluded));
  }
  const TrainingData& d = *this->DataPtr;
  if (d.Batches)
    return this->SessionPtr->createTrainer(*d.Batches, this->Config);
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
  this->Log.truncateAfter(this->GoodStep);
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
  return this->Log.rows();
}

} // namespace nv
