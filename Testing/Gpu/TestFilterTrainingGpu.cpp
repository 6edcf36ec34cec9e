// The Neural Compress filter's training loop (the engine's nv::TrainingRun, Cuda/Core/TrainingRun.h) on the CUDA
// engine: chunked queued steps, PSNR probes on their steps, abort and time budget between chunks, progress, GPU
// memory report, both training strategies. The pvbatch tests cover the same loop on the CPU (no GPU there).
// Exits with 77 (SKIP_RETURN_CODE) when no usable GPU is present.
#include "BlockingTraining.h"
#include "Core/Engine.h"
#include "Gpu/GpuEngine.h"
#include "TestHarness.h"
#include "RenderFixtures.h"
#include "SessionHelpers.h"
#include "TestVolumeView.h"
#include "Core/ResourceEstimate.h"
#include "Core/TrainingRun.h"

#include "Core/NetworkSession.h"

#include <chrono>
#include <cstdint>
#include <exception>
#include <cmath>
#include <set>
#include <thread>
#include <cstdio>
#include <string>
#include <vector>

using namespace nv;

namespace
{
constexpr int kSkip = 77;
constexpr int kN = 48;

std::vector<float> smoothVolume()
{
  std::vector<float> v(size_t(kN) * kN * kN);
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < kN; ++y)
      for (int x = 0; x < kN; ++x)
        v[(size_t(z) * kN + y) * kN + x] = float(std::sin(0.21 * x) * std::cos(0.17 * y) + 0.4 * std::sin(0.13 * z));
  return v;
}

Model smallModel(const VolumeView& vol)
{
  ModelConfig c;
  c.encoding.log2TableSize = 14;
  c.encoding.finestResolution = 96;
  Model m = nvtest::untrainedModel(c, vol, 3);
  return m;
}

TrainConfig trainConfig(TrainingStrategy strategy)
{
  TrainConfig tc;
  tc.batchSize = 16384;
  tc.seed = 5;
  tc.strategy = strategy;
  // Annealed from the first step (the default holds the rate for 500 steps, all of these runs): the run ends at its
  // best probe, so the versions counted below are the probes' and the end's only (no KeepBestNetwork restore).
  tc.optimizer.holdSteps = 0;
  return tc;
}
} // namespace

NV_TEST(filter_loop_on_gpu)
{
  const auto data = smoothVolume();
  const VolumeView vol = floatCubeView(data, kN);
  const PsnrProbe probe(vol, 7, 20000);
  for (TrainingStrategy strategy : { TrainingStrategy::GpuResident, TrainingStrategy::HostSampled })
  {
    const std::string tag = strategy == TrainingStrategy::GpuResident ? "GPU-resident" : "host-sampled";
    auto session = NetworkSession::create(Device::Cuda, smallModel(vol));
    const double before = probe.estimate(*session);
    nvtest::TrainingRequest rq;
    rq.MaxSteps = 500;
    rq.PsnrInterval = 100; // splits the 64-step chunks: 64, 36, 64, 36, ...
    std::vector<double> progress;
    rq.Progress = [&](double f) { progress.push_back(f); };
    const uint64_t version = session->version();
    const nvtest::TrainingResult r = nvtest::trainHere(*session, vol, trainConfig(strategy), rq, &probe);
    const double after = probe.estimate(*session);
    EXPECT_TRUE(session->version() == version + 5); // 4 probes and the end published to the session
    std::printf("    %s: %lld steps in %.3f s, GPU memory %.1f MiB, PSNR %.2f -> %.2f dB (probe at 400: %.2f)\n",
      tag.c_str(), (long long)r.Steps, r.Seconds, r.DeviceMemoryBytes / 1048576.0, before, after,
      r.Log.size() >= 400 ? r.Log[399].PSNR : NAN);
    EXPECT_TRUE(r.Steps == 500 && r.Log.size() == 500 && !r.Aborted && !r.TimedOut);
    EXPECT_TRUE(r.DeviceMemoryBytes > 0);
    int probes = 0;
    bool stepsInOrder = true, finite = true;
    for (size_t k = 0; k < r.Log.size(); ++k)
    {
      const LogRow& row = r.Log[k];
      stepsInOrder &= row.Step == int64_t(k + 1);
      finite &= std::isfinite(row.Loss) && row.Loss >= 0.0;
      const bool probed = !std::isnan(row.PSNR);
      probes += probed ? 1 : 0;
      EXPECT_TRUE(probed == (row.Step % 100 == 0 && row.Step != 500));
      if (probed)
        EXPECT_TRUE(row.PSNR > before); // each probe after training steps beats the untrained model
    }
    EXPECT_TRUE(stepsInOrder && finite && probes == 4);
    double early = 0.0, late = 0.0;
    for (int k = 0; k < 20; ++k)
    {
      early += r.Log[size_t(k)].Loss;
      late += r.Log[size_t(480 + k)].Loss;
    }
    double mid = 0.0;
    for (int k = 0; k < 20; ++k)
      mid += r.Log[size_t(380 + k)].Loss;
    std::printf("    %s: mean loss steps 1-20 %.4g, 381-400 %.4g, 481-500 %.4g\n", tag.c_str(), early / 20, mid / 20,
      late / 20);
    EXPECT_TRUE(late < 0.5 * early);
    // L1 on this small volume: the CPU engine's loop reaches 35.8 dB; GPU runs measured 32.8-37.2 dB (the L1
    // spread of repeated GPU runs, see TestGpuParity's curve test), so the bar is 30 dB.
    EXPECT_TRUE(after > before + 10.0 && after > 30.0);
    bool monotone = !progress.empty() && progress.back() >= 0.99;
    for (size_t k = 1; k < progress.size(); ++k)
      monotone &= progress[k] >= progress[k - 1];
    EXPECT_TRUE(monotone);
  }
}

NV_TEST(range_wider_than_the_largest_double_trains_on_gpu)
{
  // A float64 field from about -1.35e308 to +1.35e308 (max - min overflows a double) and the same field at +-1.35:
  // the GPU samples both through Core/ValueRange.h, so the two runs see the same targets (up to rounding) and end
  // at the same PSNR, finite, on both strategies. (Without Deterministic, float atomics alone spread such 300-step
  // L1 runs by about 1.5 dB.)
  const auto base = smoothVolume();
  std::vector<double> small(base.size()), huge(base.size());
  for (size_t i = 0; i < base.size(); ++i)
  {
    small[i] = double(base[i]);
    huge[i] = double(base[i]) * 1e308;
  }
  const VolumeView vs = nvtest::cubeView(small, kN), vh = nvtest::cubeView(huge, kN);
  EXPECT_TRUE(std::isinf(vh.valueMax - vh.valueMin));
  for (TrainingStrategy strategy : { TrainingStrategy::GpuResident, TrainingStrategy::HostSampled })
  {
    double psnr[2] = { 0.0, 0.0 };
    for (int k = 0; k < 2; ++k)
    {
      const VolumeView& v = k == 0 ? vs : vh;
      auto session = NetworkSession::create(Device::Cuda, smallModel(v));
      TrainConfig tc = trainConfig(strategy);
      tc.deterministic = true; // no atomics-order noise: the runs differ by the targets' rounding only
      auto trainer = session->createTrainer(v, tc);
      trainer->steps(300, nullptr);
      trainer->publish();
      psnr[k] = PsnrProbe(v, 7, 20000).estimate(*session);
    }
    std::printf("    %s: +-1.35 %.3f dB, +-1.35e308 %.3f dB\n",
      strategy == TrainingStrategy::GpuResident ? "GPU-resident" : "host-sampled", psnr[0], psnr[1]);
    EXPECT_TRUE(std::isfinite(psnr[1]) && psnr[0] > 25.0 && std::fabs(psnr[0] - psnr[1]) < 1.0);
  }
}

NV_TEST(memory_estimates_against_the_gpu)
{
  // The GPU branch of Core/ResourceEstimate: the free memory the runtime reports; a run that fits is accepted and
  // its estimate is not below what its trainer then holds; a table no GPU holds is refused with the GPU's figures
  // before anything is allocated.
  int64_t freeBytes = -1, totalBytes = 0;
  EXPECT_TRUE(deviceMemoryInfo(freeBytes, totalBytes) && freeBytes > 0 && totalBytes >= freeBytes);
  const auto data = smoothVolume();
  const VolumeView vol = floatCubeView(data, kN);
  const Model m = smallModel(vol);
  TrainConfig tc = trainConfig(TrainingStrategy::GpuResident);
  const MemoryEstimate fits = trainingMemory(m.config(), tc, Device::Cuda, vol.bytes());
  bool accepted = true;
  try
  {
    checkMemory(fits, "training this network", "lower Log2TableSize", freeBytes, INT64_MAX);
  }
  catch (const std::exception&)
  {
    accepted = false;
  }
  auto session = NetworkSession::create(Device::Cuda, m);
  auto trainer = session->createTrainer(vol, tc);
  const int64_t held = trainer->deviceMemoryBytes();
  std::printf("    GPU %.0f of %.0f MiB free; small run: estimate %.1f MiB, trainer holds %.1f MiB\n",
    freeBytes / 1048576.0, totalBytes / 1048576.0, fits.deviceBytes / 1048576.0, held / 1048576.0);
  EXPECT_TRUE(accepted && held > 0 && held <= fits.deviceBytes);
  // 2^24 x 4 x 16 table, width 128 x 8 layers, batch 2^24: about 86 GB on a GPU, more than any H100's 80 GB.
  ModelConfig huge = m.config();
  huge.encoding.levels = 16;
  huge.encoding.featuresPerLevel = 4;
  huge.encoding.log2TableSize = 24;
  huge.encoding.finestResolution = 8192;
  huge.network.width = 128;
  huge.network.hiddenLayers = 8;
  TrainConfig hugeBatch = tc;
  hugeBatch.batchSize = 1 << 24;
  const MemoryEstimate tooBig = trainingMemory(huge, hugeBatch, Device::Cuda, vol.bytes());
  std::string message;
  try
  {
    checkMemory(tooBig, "training this network", "lower Log2TableSize", freeBytes, INT64_MAX);
  }
  catch (const std::exception& e)
  {
    message = e.what();
  }
  std::printf("    %.1f GB run: %s\n", tooBig.deviceBytes / 1e9, message.c_str());
  EXPECT_TRUE(message.find("of GPU memory") != std::string::npos && message.find("free on the GPU") != std::string::npos);
}

NV_TEST(filter_loop_abort_and_time_budget_on_gpu)
{
  const auto data = smoothVolume();
  const VolumeView vol = floatCubeView(data, kN);
  {
    // Abort is checked between chunks: the first check lets one chunk (64 queued steps) run, the second aborts.
    auto session = NetworkSession::create(Device::Cuda, smallModel(vol));
    nvtest::TrainingRequest rq;
    rq.MaxSteps = 100000;
    int checks = 0;
    rq.ShouldAbort = [&] { return ++checks >= 2; };
    const nvtest::TrainingResult r = nvtest::trainHere(*session, vol, trainConfig(TrainingStrategy::Auto), rq, nullptr);
    std::printf("    abort: %lld steps, aborted %d\n", (long long)r.Steps, int(r.Aborted));
    EXPECT_TRUE(r.Aborted && r.Steps == 64 && r.Log.size() == 64);
  }
  {
    auto session = NetworkSession::create(Device::Cuda, smallModel(vol));
    nvtest::TrainingRequest rq;
    rq.MaxSteps = 10000000;
    rq.TimeBudget = 0.3;
    const nvtest::TrainingResult r = nvtest::trainHere(*session, vol, trainConfig(TrainingStrategy::Auto), rq, nullptr);
    std::printf("    time budget 0.3 s: %lld steps in %.3f s, timed out %d\n", (long long)r.Steps, r.Seconds,
      int(r.TimedOut));
    EXPECT_TRUE(r.TimedOut && r.Steps > 64 && r.Steps < rq.MaxSteps && r.Steps % 64 == 0);
    EXPECT_TRUE(r.Seconds < 0.3 + 0.25); // one chunk past the budget at most, plus the final sync
  }
}

NV_TEST(time_budget_bounds_training_and_measurement_on_gpu)
{
  // As the filter runs it: the budget bounds the steps, probes and the measurement over every voxel at the phase end
  // (FinalSamples at the measured inference rate) within 10%.
  const int n = 160;
  std::vector<float> data(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        data[(size_t(z) * n + y) * n + x] = float(std::sin(0.11 * x) * std::cos(0.07 * y) + 0.3 * std::sin(0.05 * z * x));
  const VolumeView vol = floatCubeView(data, n);
  auto training = std::make_shared<TrainingData>();
  training->Field.View = vol;
  training->Probe.reset(new PsnrProbe(vol, 1, 65536));
  ModelConfig c;
  c.encoding.log2TableSize = 19;
  std::shared_ptr<NetworkSession> session = NetworkSession::create(Device::Cuda, nvtest::untrainedModel(c, vol, 3));
  RunLimits limits;
  limits.MaxSteps = 100000000;
  limits.PsnrInterval = 100;
  limits.TimeBudget = 2.0;
  limits.FinalSamples = vol.count();
  double measureSeconds = 0.0, psnr = 0.0;
  TrainingRun run(session, training, trainConfig(TrainingStrategy::Auto), limits, [&](TrainingRun& r, const RunStatus&) {
    const auto t0 = std::chrono::steady_clock::now();
    psnr = compareToSource(r.session(), vol).psnr;
    measureSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  });
  const auto start = std::chrono::steady_clock::now();
  run.runHere(nullptr, nullptr);
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const RunStatus st = run.status();
  std::printf("    budget 2 s: %lld steps, %.3f s training + %.3f s measuring (%.2f dB) = %.3f s (reserve %.3f s)\n",
    (long long)st.Steps, st.Seconds, measureSeconds, psnr, total, run.finalReserveSeconds());
  EXPECT_TRUE(st.EndReason == "time budget");
  EXPECT_TRUE(total >= 1.8 && total <= 2.2);
}

NV_TEST(background_run_while_rendering_on_gpu)
{
  // The online filter on the GPU: a background run trains and publishes while this thread renders; every few frames
  // show a newer network; pause holds it, stop ends it within 0.2 s with nothing published after.
  const auto data = smoothVolume();
  auto d = std::make_shared<TrainingData>();
  d->Field.View = floatCubeView(data, kN);
  std::shared_ptr<NetworkSession> session = NetworkSession::create(Device::Cuda, smallModel(d->Field.View));
  RunLimits limits;
  limits.MaxSteps = 3000;
  limits.PublishSeconds = 0.01;
  TrainingRun run(session, d, trainConfig(TrainingStrategy::Auto), limits, nullptr);
  RenderRequest q = nvtest::blobRequest(session->currentModel(), RenderPath::Decode, ShadingMode::RayMarch, 256,
    256);
  q.samplesPerPixel = 1;
  RenderResult image;
  run.startInBackground();
  std::set<uint64_t> versions;
  int frames = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (run.status().Steps < 1000 && frames < 100000)
  {
    session->render(q, image);
    versions.insert(session->version());
    ++frames;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("    %d frames in %.2f s while training (%zu network versions seen), %lld steps\n", frames, seconds,
    versions.size(), (long long)run.status().Steps);
  EXPECT_TRUE(versions.size() >= 5);
  run.pause();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const int64_t paused = run.status().Steps;
  const uint64_t pausedVersion = session->version();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_TRUE(run.status().Steps == paused && session->version() == pausedVersion);
  run.resume();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const auto s0 = std::chrono::steady_clock::now();
  run.stop();
  EXPECT_TRUE(run.wait(5.0));
  const double latency = std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
  std::printf("    stop latency %.4f s at %lld steps\n", latency, (long long)run.status().Steps);
  EXPECT_TRUE(latency < 0.2);
  const uint64_t stoppedVersion = session->version();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_TRUE(session->version() == stoppedVersion);
  run.extend(128, true);
  EXPECT_TRUE(run.wait(30.0));
  EXPECT_TRUE(run.status().State == RunState::Finished);
}

NV_TEST(deterministic_run_on_gpu_is_bitwise_repeatable)
{
  // The filter's Deterministic option on CUDA: a fixed step count, the seed and fixed-point gradient sums give the
  // same network bit for bit, whether the run goes in the calling thread or in the background with pauses and
  // publishes in between, and PSNR probes that only watch (KeepBest off) change nothing; with KeepBest the network
  // kept (that of the best probe, from snapshots at every probe) is the same in both kinds of run too.
  const auto data = smoothVolume();
  std::vector<std::vector<float>> params;
  for (int k = 0; k < 5; ++k)
  {
    auto d = std::make_shared<TrainingData>();
    d->Field.View = floatCubeView(data, kN);
    const bool probes = k >= 2, background = k == 1 || k == 3;
    if (probes)
      d->Probe.reset(new PsnrProbe(d->Field.View, 7, 20000));
    std::shared_ptr<NetworkSession> session = NetworkSession::create(Device::Cuda, smallModel(d->Field.View));
    TrainConfig tc = trainConfig(k == 1 ? TrainingStrategy::GpuResident : TrainingStrategy::Auto);
    tc.deterministic = true;
    RunLimits limits;
    limits.MaxSteps = 700;
    limits.PublishSeconds = 0.005;
    limits.PsnrInterval = probes ? 50 : 0;
    limits.KeepBest = k >= 3;
    TrainingRun run(session, d, tc, limits, nullptr);
    if (!background)
      run.runHere(nullptr, nullptr);
    else
    {
      run.startInBackground();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      run.pause();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      run.resume();
      EXPECT_TRUE(run.wait(60.0));
    }
    EXPECT_TRUE(run.status().Steps == 700);
    params.push_back(session->currentModel().params());
  }
  auto differ = [&](int a, int b) {
    size_t n = 0;
    for (size_t i = 0; i < params[size_t(a)].size(); ++i)
      n += params[size_t(a)][i] != params[size_t(b)][i] ? 1 : 0;
    return n;
  };
  const size_t d1 = differ(0, 1), d2 = differ(0, 2), d34 = differ(3, 4);
  std::printf("    deterministic on CUDA: %zu and %zu of %zu parameters differ from the first run; KeepBest runs: %zu "
              "differ (the kept network differs from the last in %zu)\n", d1, d2, params[0].size(), d34, differ(0, 3));
  EXPECT_TRUE(d1 == 0 && d2 == 0 && d34 == 0);
}

int main(int argc, char** argv)
{
  std::string why;
  if (!gpu::deviceUsable(&why))
  {
    std::printf("SKIPPED: no usable GPU (%s)\n", why.c_str());
    return kSkip;
  }
  return nvtest::runCases(argc, argv);
}
