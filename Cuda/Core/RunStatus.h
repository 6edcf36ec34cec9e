// NeuralVolume engine: what a training run (TrainingRun.h) reports while it trains: its state, its status (steps,
// time, loss, PSNR, notes and warnings) and the rows of its log (one per step, thinned on long runs: TrainingLog.h).
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace nv
{

enum class RunState : int
{
  Starting = 0, ///< background run: the trainer is being created
  Running = 1,
  Paused = 2,
  Finishing = 3, ///< the phase ended; the phase-end hook is running
  Finished = 4,  ///< a phase ended at its limit; extend() continues
  Stopped = 5,   ///< stop(): final, extend() still continues from the trainer's state
  Failed = 6
};
/// "Training", "Paused", ... (shown by the Neural Compress panel).
const char* runStateName(RunState s);
/// Finished, Stopped or Failed: nothing runs until extend().
bool isSettled(RunState s);

struct RunStatus
{
  RunState State = RunState::Starting;
  int64_t Steps = 0;
  int64_t TargetSteps = 0;  ///< step count at which the current phase ends
  double Seconds = 0.0;     ///< active training time of the whole run
  double Loss = 0.0;        ///< last step's loss
  double Psnr = std::numeric_limits<double>::quiet_NaN(); ///< last probe
  std::string EndReason;    ///< why the last phase ended ("step limit", "time budget", "target PSNR", "stopped")
  std::string Error;        ///< Failed: the engine's message
  uint64_t Serial = 0;      ///< changes whenever anything here or the published network changes
  int64_t DeviceMemoryBytes = 0;
  /// What the run did about the network on its own in the normal course (the best network kept), one line each.
  std::vector<std::string> Notes;
  /// What went wrong and was recovered from (a rollback after a divergence): the user should know; one line each.
  std::vector<std::string> Warnings;
};

/// One training step of a run's log.
struct LogRow
{
  int64_t Step;
  double Loss;
  double LearningRate;
  double ElapsedSeconds;
  double PSNR; ///< NaN when not evaluated at this step
};

} // namespace nv
