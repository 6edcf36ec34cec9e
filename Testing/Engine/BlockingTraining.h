// Test shorthand over nv::TrainingRun: a run of one phase in the calling thread on a session the caller keeps, with the
// probe, abort, time budget and progress of a request, and the run's figures and log as the result. The Neural
// Compress filter drives nv::TrainingRun itself; the GPU tests use this to check its CUDA path in one call.
#pragma once

#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "Core/PsnrProbe.h"
#include "Core/TrainingRun.h"

#include <functional>
#include <memory>
#include <vector>

namespace nvtest
{

struct TrainingRequest
{
  int64_t MaxSteps = 0;
  double TimeBudget = 0.0; ///< seconds, 0 = unlimited
  int PsnrInterval = 0;
  std::function<bool()> ShouldAbort;
  std::function<void(double)> Progress;
};

struct TrainingResult
{
  int64_t Steps = 0;
  double Seconds = 0.0;
  double FinalLoss = 0.0;
  bool Aborted = false;
  bool TimedOut = false;
  int64_t DeviceMemoryBytes = 0; ///< GPU memory held by the trainer (0 on the CPU)
  std::vector<nv::LogRow> Log;
};

/// Trains the session's network on `view`; the trained parameters are published to the session (probes publish on
/// their steps). A failed run throws its nv::Error.
inline TrainingResult trainHere(nv::NetworkSession& session, const nv::VolumeView& view, const nv::TrainConfig& config,
  const TrainingRequest& request, const nv::PsnrProbe* probe)
{
  auto data = std::make_shared<nv::TrainingData>();
  data->Field.View = view;
  if (probe && request.PsnrInterval > 0)
    data->Probe.reset(new nv::PsnrProbe(*probe));
  nv::RunLimits limits;
  limits.MaxSteps = request.MaxSteps;
  limits.TimeBudget = request.TimeBudget;
  limits.PsnrInterval = request.PsnrInterval;
  std::shared_ptr<nv::NetworkSession> unowned(&session, [](nv::NetworkSession*) {});
  nv::TrainingRun run(unowned, data, config, limits, nullptr);
  run.runHere(request.ShouldAbort, request.Progress);
  const nv::RunStatus status = run.status();
  if (status.State == nv::RunState::Failed)
    throw nv::Error(status.Error);
  TrainingResult result;
  result.Steps = status.Steps;
  result.Seconds = status.Seconds;
  result.FinalLoss = status.Loss;
  result.Aborted = status.EndReason == "stopped";
  result.TimedOut = status.EndReason == "time budget";
  result.DeviceMemoryBytes = status.DeviceMemoryBytes;
  result.Log = run.log();
  return result;
}

} // namespace nvtest
