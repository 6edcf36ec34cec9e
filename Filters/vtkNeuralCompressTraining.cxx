// The engine-facing training loop of vtkNeuralCompress (PSNR probe, chunked steps, abort, time budget, progress).
// Free of VTK, so the GPU tests (Testing/Gpu) build it with the engine alone and run the filter's CUDA path on a
// GPU machine without ParaView.
#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralTrainingRun.h"

#include "Core/Error.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>

namespace vtkNeuralCompressInternals
{
double PsnrFromMse(double mse)
{
  return mse > 0.0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
}

PsnrProbe::PsnrProbe(const nv::VolumeView& view, uint64_t seed, int64_t maxSamples)
{
  const int64_t n = view.count();
  const double range = view.valueMax - view.valueMin;
  const double inv = range > 0.0 ? 1.0 / range : 0.0;
  std::mt19937_64 rng(seed ^ 0x5EED5EEDull);
  std::uniform_int_distribution<int64_t> pick(0, std::max<int64_t>(n - 1, 0));
  const int64_t want = std::min(n, maxSamples);
  const int64_t maxTries = want * 4 + 16;
  Coords.reserve(static_cast<size_t>(want) * 3);
  Expected.reserve(static_cast<size_t>(want));
  for (int64_t t = 0; t < maxTries && static_cast<int64_t>(Expected.size()) < want; ++t)
  {
    // Every voxel when the volume is small, else a random subset.
    const int64_t i = n <= maxSamples ? t : pick(rng);
    if (i >= n)
    {
      break;
    }
    const double v = view.at(i);
    if (!std::isfinite(v))
    {
      continue;
    }
    const int64_t x = i % view.dims[0];
    const int64_t y = (i / view.dims[0]) % view.dims[1];
    const int64_t z = i / (view.dims[0] * view.dims[1]);
    const int64_t idx[3] = { x, y, z };
    for (int d = 0; d < 3; ++d)
    {
      const int64_t m = view.dims[d];
      Coords.push_back(m > 1 ? static_cast<float>(static_cast<double>(idx[d]) / (m - 1)) : 0.5f);
    }
    Expected.push_back(static_cast<float>((v - view.valueMin) * inv));
  }
}

PsnrProbe::PsnrProbe(const std::vector<float>& xyz, const std::vector<float>& values, int64_t maxSamples)
{
  const int64_t n = static_cast<int64_t>(values.size());
  const int64_t stride = std::max<int64_t>(1, (n + maxSamples - 1) / std::max<int64_t>(maxSamples, 1));
  for (int64_t i = 0; i < n; i += stride)
  {
    if (!std::isfinite(values[size_t(i)]))
      continue;
    Coords.insert(Coords.end(), xyz.begin() + 3 * i, xyz.begin() + 3 * i + 3);
    Expected.push_back(values[size_t(i)]);
  }
}

double PsnrProbe::Estimate(nv::NetworkSession& session) const
{
  const int64_t n = static_cast<int64_t>(Expected.size());
  if (n == 0)
  {
    return std::numeric_limits<double>::quiet_NaN();
  }
  std::vector<float> out(static_cast<size_t>(n));
  session.inferPoints(Coords.data(), n, out.data(), nv::Memory::Host);
  double se = 0.0;
  for (int64_t i = 0; i < n; ++i)
  {
    const double d = static_cast<double>(out[i]) - Expected[i];
    se += d * d;
  }
  return PsnrFromMse(se / static_cast<double>(n));
}

TrainingResult Train(nv::NetworkSession& session, const nv::VolumeView& view, const nv::TrainConfig& config,
  const TrainingRequest& request, const PsnrProbe* probe)
{
  // One training loop: a TrainingRun in the calling thread (the filter's blocking mode), on a session this call does
  // not own.
  auto data = std::make_shared<TrainingData>();
  data->Field.View = view;
  if (probe && request.PsnrInterval > 0)
  {
    data->Probe.reset(new PsnrProbe(*probe));
  }
  RunLimits limits;
  limits.MaxSteps = request.MaxSteps;
  limits.TimeBudget = request.TimeBudget;
  limits.PsnrInterval = request.PsnrInterval;
  std::shared_ptr<nv::NetworkSession> unowned(&session, [](nv::NetworkSession*) {});
  TrainingRun run(unowned, data, config, limits, nullptr);
  run.RunHere(request.ShouldAbort, request.Progress);
  const RunStatus status = run.Status();
  if (status.State == RunState::Failed)
  {
    throw nv::Error(status.Error);
  }
  TrainingResult result;
  result.Steps = status.Steps;
  result.Seconds = status.Seconds;
  result.FinalLoss = status.Loss;
  result.Aborted = status.EndReason == "stopped";
  result.TimedOut = status.EndReason == "time budget";
  result.DeviceMemoryBytes = status.DeviceMemoryBytes;
  result.Log = run.Log();
  return result;
}

//------------------------------------------------------------------------------
// TrainingRun: the time budget's cap of the batch (vtkNeuralTrainingRun.h).
int TrainingRun::BudgetedBatch(double stepSeconds, int batch) const
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

void TrainingRun::ResizeBatch(int batch, double stepSeconds)
{
  this->Calibrating = false;
  const int previous = this->Config.batchSize;
  std::unique_ptr<nv::Trainer> trainer;
  if (batch != previous) // else the calibration batch is the one to keep
  {
    this->Publish(); // the new trainer starts from the network trained so far
    this->Trainer.reset();
    this->Config.batchSize = batch;
    this->StepSeconds = stepSeconds * static_cast<double>(batch) / static_cast<double>(previous); // until measured
    trainer = this->CreateTrainer();
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

} // namespace vtkNeuralCompressInternals
