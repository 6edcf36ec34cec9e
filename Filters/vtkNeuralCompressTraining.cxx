// The engine-facing training loop of vtkNeuralCompress (PSNR probe, chunked steps, abort, time budget, progress).
// Free of VTK, so the GPU tests (Testing/Gpu) build it with the engine alone and run the filter's CUDA path on a
// GPU machine without ParaView.
#include "vtkNeuralCompressInternals.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>

namespace vtkNeuralCompressInternals
{
namespace
{
double Seconds(std::chrono::steady_clock::time_point since)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}
} // namespace

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
  TrainingResult result;
  const auto start = std::chrono::steady_clock::now();
  auto trainer = session.createTrainer(view, config);
  result.DeviceMemoryBytes = trainer->deviceMemoryBytes();
  double lastProgress = -1.0;
  // Steps run in chunks through Trainer::steps (queued back to back on a GPU, one loss read-back per chunk); a
  // chunk ends at the next PSNR probe and lasts at most ~20 ms on a GPU (64 steps), so abort and the time budget
  // are checked often. On the CPU a chunk is one step.
  const int64_t chunkMax = trainer->device() == nv::Device::Cuda ? 64 : 1;
  std::vector<float> losses(static_cast<size_t>(chunkMax));
  for (int64_t step = 1; step <= request.MaxSteps;)
  {
    if (request.ShouldAbort && request.ShouldAbort())
    {
      result.Aborted = true;
      break;
    }
    const double before = Seconds(start);
    if (request.TimeBudget > 0.0 && before >= request.TimeBudget)
    {
      result.TimedOut = true;
      break;
    }
    int64_t count = std::min(chunkMax, request.MaxSteps - step + 1);
    if (probe && request.PsnrInterval > 0)
      count = std::min(count, request.PsnrInterval - (step - 1) % request.PsnrInterval);
    trainer->steps(count, losses.data());
    const double after = Seconds(start);
    for (int64_t k = 0; k < count; ++k, ++step)
    {
      LogRow row;
      row.Step = step;
      row.LearningRate = config.optimizer.learningRateAt(step);
      row.Loss = losses[static_cast<size_t>(k)];
      row.ElapsedSeconds = before + (after - before) * static_cast<double>(k + 1) / static_cast<double>(count);
      row.PSNR = std::numeric_limits<double>::quiet_NaN();
      if (probe && request.PsnrInterval > 0 && step % request.PsnrInterval == 0 && step != request.MaxSteps)
      {
        trainer->publish();
        row.PSNR = probe->Estimate(session);
      }
      result.Log.push_back(row);
      result.Steps = step;
      result.FinalLoss = row.Loss;
    }
    if (request.Progress)
    {
      const double elapsed = Seconds(start);
      double fraction = static_cast<double>(step - 1) / static_cast<double>(request.MaxSteps);
      if (request.TimeBudget > 0.0)
      {
        fraction = std::max(fraction, elapsed / request.TimeBudget);
      }
      fraction = std::min(fraction, 1.0);
      if (fraction - lastProgress >= 0.01)
      {
        request.Progress(fraction);
        lastProgress = fraction;
      }
    }
  }
  trainer->publish();
  result.Seconds = Seconds(start);
  return result;
}

} // namespace vtkNeuralCompressInternals
