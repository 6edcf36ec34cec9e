// NeuralVolume engine: one training run of a network session, in the calling thread or in a background thread, with
// the controls of the Neural Compress panel (pause, resume, continue for N steps, fast-forward, stop) and a status
// (RunStatus.h) that the GUI polls. The Neural Compress filter drives it; the engine tests run it without VTK.
//
// A run trains in phases. The first phase ends at its step limit, its time budget (active training time: paused time
// does not count) or its target PSNR; extend() starts another phase (or lengthens the current one) from the state the
// trainer has (parameters and Adam moments), so "continue for N steps" is exact. At the end of every phase the
// trainer's parameters are published to the session and the phase-end hook runs in the training thread (the filter
// decodes and measures there, so the GUI thread never does heavy work). stop() ends a background run at once: the
// network the session shows is the one last published; a chunk in flight is discarded, nothing is published after
// stop(). A run in the calling thread stops between chunks (abort) and keeps the steps done.
#pragma once

#include "Engine.h"
#include "Model.h"
#include "NetworkSession.h"
#include "RunStatus.h"
#include "TrainingData.h"
#include "TrainingLog.h"

#include <chrono>
#include <condition_variable>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace nv
{

struct RunLimits
{
  int64_t MaxSteps = 0;
  /// Seconds of the first phase, 0 = unlimited: wall time while the run is not paused (steps, probes, publishes and
  /// snapshots), plus the measurement at its end (FinalSamples), so a caller that subtracts its own preparation
  /// bounds the whole job.
  double TimeBudget = 0.0;
  /// Network evaluations the phase-end hook makes (the filter's measurement over every voxel and decode): the budget
  /// keeps time for them at the inference rate the probes measured (0: nothing reserved).
  int64_t FinalSamples = 0;
  double TargetPsnr = 0.0;     ///< dB on the probe, 0 = off
  int PsnrInterval = 0;        ///< steps between probes (0 = none)
  double PublishSeconds = 0.1; ///< background runs: the session shows a new network at least this often
  int64_t FirstStep = 0;       ///< steps the network had before this run (a run continuing a cached network)
  /// At the end of a phase, the network of the best probe replaces the last one when it was better (needs probes).
  bool KeepBest = true;
};

class TrainingRun
{
public:
  /// Called in the training thread after the last publish of a phase (and after Stop); may throw nv::Error.
  using PhaseEndHook = std::function<void(TrainingRun&, const RunStatus&)>;

  TrainingRun(std::shared_ptr<NetworkSession> session, std::shared_ptr<TrainingData> data,
    const TrainConfig& config, const RunLimits& limits, PhaseEndHook onPhaseEnd);
  ~TrainingRun(); ///< stops and joins the background thread
  TrainingRun(const TrainingRun&) = delete;
  TrainingRun& operator=(const TrainingRun&) = delete;

  /// Runs the first phase in the calling thread. `abort` is polled between chunks of steps (the run then ends as
  /// Stopped); `progress` gets the phase's fraction done. Engine errors end the run as Failed (no exception).
  void runHere(const std::function<bool()>& abort, const std::function<void(double)>& progress);
  /// Runs the first phase (and every later one) in a background thread; returns at once.
  void startInBackground();
  /// Work the run does first, in its own thread (runHere: the calling thread) before the trainer is created, while
  /// the state is Starting: installing the session's initial network, so that a caller on a GUI thread never
  /// allocates or initialises a large table. Its seconds count against the first phase's time budget; an exception
  /// fails the run. Set before the run starts.
  void setPrologue(std::function<void()> prologue) { this->Prologue = std::move(prologue); }
  /// From the prologue: seconds of it that do not count against the first phase's time budget (SizeForPSNR's search
  /// of candidate sizes, each trained on its own: the network then gets the whole budget).
  void excludeFromBudget(double seconds) { this->PrologueExcluded += seconds; }

  void pause();
  void resume();
  /// `steps` more steps: lengthens the current phase (also before the run starts), or starts a new one after a phase
  /// ended (without a time budget or target PSNR). fastForward: no intermediate publishes until that phase ends (the paper's button).
  /// In a run started with runHere, a new phase also runs in the calling thread.
  void extend(int64_t steps, bool fastForward);
  /// Ends the run now (see the file comment).
  void stop();
  /// Seconds the first phase keeps for its end (Limits.FinalSamples at the measured inference rate; 0 before any
  /// measurement).
  double finalReserveSeconds() const;
  /// Blocks while the run is Starting, Running, Finishing or Paused, at most `timeoutSeconds` (< 0: no limit).
  /// Returns true when the run has settled (Finished, Stopped or Failed).
  bool wait(double timeoutSeconds);

  RunStatus status() const;
  std::vector<LogRow> log() const;
  NetworkSession& session() { return *this->SessionPtr; }
  const TrainingData& data() const { return *this->DataPtr; }
  bool inBackground() const { return this->Background; }

private:
  /// A trainer on the field, on the bank of points when the data has one, or on its out-of-core batch source (after
  /// the prologue).
  std::unique_ptr<nv::Trainer> createTrainer();
  std::function<void()> Prologue;
  double PrologueExcluded = 0.0; ///< excludeFromBudget (the run's thread only)
  void worker();
  /// One phase (TrainingRunPhase.cpp): chunks of steps until a limit, the target PSNR or a stop.
  void runPhase(const std::function<bool()>& abort, const std::function<void(double)>& progress);
  struct PhaseLoop;
  /// The next chunk (steps, length) under the lock, after a pause; false with the reason when the phase ends.
  bool planChunk(PhaseLoop& loop, const std::function<bool()>& abort);
  /// Paused (background runs): waits for resume() or stop(); paused time is not on the run's clock.
  void waitWhilePaused(std::unique_lock<std::mutex>& lock, PhaseLoop& loop);
  /// Trains the chunk; false when it diverged and the run rolled back (throws after kMaxRollbacks).
  bool trainChunk(PhaseLoop& loop);
  /// The chunk's log rows and status; probeNow when a PSNR probe is due. False when stop() came meanwhile.
  bool logChunk(PhaseLoop& loop, bool& probeNow);
  /// The probe (and its snapshot), or a snapshot, or a background publish; false when the target PSNR is reached.
  bool probeOrPublish(PhaseLoop& loop, bool probeNow);
  /// Under a time budget: the batch capped to the measured step time (budgetedBatch, resizeBatch).
  void fitBatchToBudget(PhaseLoop& loop);
  void reportProgress(PhaseLoop& loop, const std::function<void(double)>& progress);
  static double secondsSince(std::chrono::steady_clock::time_point t);
  void endPhase(const std::string& reason);
  void fail(const std::string& message);
  void publish();
  /// After a chunk with a diverged loss (not finite or above kDivergedLoss): the network of the last good snapshot, a learning rate 10x lower and a
  /// new trainer; false (the run fails) after kMaxRollbacks.
  bool rollBack(int64_t failedStep, double loss);
  /// Phase end: the best probe's network replaces the last one when it was better (Limits.KeepBest).
  void keepBestNetwork();
  /// The time budget: a batch larger than kCalibrationBatch first trains one step of kCalibrationBatch samples,
  /// whose time caps the batch so that one step takes at most kStepShare of the budget (never below
  /// kCalibrationBatch); a later step above twice that share caps it again. Returns the batch for the next trainer
  /// (the current one when no cap applies).
  int budgetedBatch(double stepSeconds, int batch) const;
  /// A new trainer of `batch` samples from the published network (fresh optimizer state, the schedule restarts).
  void resizeBatch(int batch, double stepSeconds);
  /// An annealed learning-rate schedule ends at the phase's last step: OptimizerConfig::plannedSteps of the trainer
  /// becomes the steps left to the step target or, under a time budget, those the measured step rate allows in the
  /// budget left (re-estimated before every chunk). Phases added after the first keep the plan (the rate stays at
  /// its floor instead of rising again).
  void planSchedule(double phaseSeconds);
  bool PlanOpen = true;        ///< the first phase: planSchedule updates the plan
  static constexpr int kCalibrationBatch = 65536;
  static constexpr double kStepShare = 0.05;
  static constexpr double kBudgetOverrun = 0.05; ///< a step may end this share of the budget past it, no more
  static constexpr double kMaxReserveShare = 0.5; ///< the phase end's reserve takes at most this share of the budget
  int RequestedBatch = 0;      ///< the configured batch (Config.batchSize may be capped below it)
  bool Calibrating = false;    ///< the trainer runs the calibration batch
  double StepSeconds = 0.0;    ///< seconds of the last step (0: none yet)
  static constexpr int kMaxRollbacks = 10;
  static constexpr double kDivergedLoss = 1e3; ///< a step loss above this (or not finite) is a divergence
  /// Takes a snapshot of the trainer's network (a host copy of its parameters) when they are all finite: the rollback
  /// point, and the best network when its probe PSNR is the best so far.
  void snapshot(double probePsnr);
  /// Whether a snapshot is due now: Deterministic runs at every probe (or every kSnapshotSteps without probes), so the
  /// network kept does not depend on timing; others when the probe improved or a second has passed, and never more
  /// often than 20 copies' time (the copies cost at most 5% of training).
  bool snapshotDue(bool probe, bool improved) const;
  static constexpr double kSnapshotSeconds = 1.0;
  static constexpr int64_t kSnapshotSteps = 250;

  Model Good;              ///< the last snapshot whose steps all had finite losses
  Model Candidate;         ///< the buffer the next snapshot is copied into (swapped with Good)
  int64_t GoodStep = -1;       ///< its step (-1: none yet)
  int Rollbacks = 0;
  int64_t ScheduleStart = 0;   ///< the step the current trainer started at (its learning-rate schedule restarts)
  Model Best;              ///< the network of the best probe so far
  double BestPsnr = -std::numeric_limits<double>::infinity();
  int64_t BestStep = -1;
  std::chrono::steady_clock::time_point LastSnapshot;
  double SnapshotCost = 0.0; ///< seconds the last snapshot took

  std::shared_ptr<NetworkSession> SessionPtr;
  std::shared_ptr<TrainingData> DataPtr;
  TrainConfig Config;
  RunLimits Limits;
  PhaseEndHook OnPhaseEnd;
  std::unique_ptr<nv::Trainer> Trainer;

  mutable std::mutex Mutex;
  std::condition_variable Changed;
  RunStatus Current;
  TrainingLog Log;             ///< one row per step, thinned past TrainingLog::kMaxRows
  bool PauseRequested = false;
  bool StopRequested = false;
  bool Quit = false;
  bool PhaseRequested = false; ///< extend() after a phase ended
  bool FastForward = false;
  double PhaseBudget = 0.0;    ///< active seconds allowed to this phase (0 = unlimited)
  double InferSecondsPerSample = 0.0; ///< measured once by measureInference (0: not yet)
  /// Times the phase end's work per sample (a decode to host doubles and a comparison, on up to 2^17 samples:
  /// InferSecondsPerSample), for the budget's reserve.
  void measureInference();
  double PhaseStartSeconds = 0.0;
  double PhaseTargetPsnr = 0.0;
  bool Background = false;
  std::thread Thread;
};

} // namespace nv
