// The engine's training run (Core/TrainingRun.h, what the Neural Compress filter drives) on the CPU engine: background
// training publishing to the session, pause / resume / continue / fast-forward step counts, stop latency, target
// PSNR and time budget, bit-for-bit determinism, and warm start against cold start.
#include "Core/Engine.h"
#include "Core/ThreadPriority.h"
#include "Core/TrainingRun.h"
#include "Cpu/ThreadPool.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

using namespace nv;
using Clock = std::chrono::steady_clock;

namespace
{
constexpr int kN = 32;

std::vector<float> analyticVolume(double phase)
{
  std::vector<float> v(size_t(kN) * kN * kN);
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < kN; ++y)
      for (int x = 0; x < kN; ++x)
      {
        const double X = double(x) / (kN - 1), Y = double(y) / (kN - 1), Z = double(z) / (kN - 1);
        v[(size_t(z) * kN + y) * kN + x] =
          float(100.0 * (std::sin(6 * X + phase) * std::cos(5 * Y) + 0.5 * std::sin(7 * Z - phase)));
      }
  return v;
}

std::shared_ptr<TrainingData> data(const std::vector<float>& values, bool probe = true)
{
  auto d = std::make_shared<TrainingData>();
  VolumeView& vol = d->Field.View;
  vol.data = values.data();
  vol.type = ScalarType::Float32;
  vol.dims[0] = vol.dims[1] = vol.dims[2] = kN;
  const VolumeStats s = computeStats(vol);
  vol.valueMin = s.min;
  vol.valueMax = s.max;
  if (probe)
    d->Probe.reset(new PsnrProbe(vol, 1, 8192));
  return d;
}

Model model(const TrainingData& d, uint64_t seed)
{
  ModelConfig c;
  c.encoding.levels = 6;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = 12;
  c.encoding.finestResolution = 64;
  c.network.width = 16;
  c.network.hiddenLayers = 1;
  Model m(c);
  m.initialize(seed);
  m.source.valueMin = d.Field.View.valueMin;
  m.source.valueMax = d.Field.View.valueMax;
  return m;
}

TrainConfig trainConfig()
{
  TrainConfig t;
  t.batchSize = 4096;
  t.seed = 7;
  t.threads = 2;
  return t;
}

RunLimits limits(int64_t steps, int psnrInterval = 0)
{
  RunLimits l;
  l.MaxSteps = steps;
  l.PsnrInterval = psnrInterval;
  l.PublishSeconds = 0.02;
  return l;
}

/// Waits until `pred` or `seconds` pass.
template <typename P>
bool waitFor(P pred, double seconds)
{
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  while (!pred())
  {
    if (Clock::now() > until)
      return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

double psnrOf(NetworkSession& s, const VolumeView& vol)
{
  return compareToSource(s, vol).psnr;
}
} // namespace

NV_TEST(background_run_publishes_while_the_caller_goes_on)
{
  const std::vector<float> values = analyticVolume(0.0);
  auto d = data(values);
  std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
  int hookCalls = 0;
  TrainingRun run(s, d, trainConfig(), limits(400, 50),
    [&](TrainingRun&, const RunStatus&) { ++hookCalls; });
  const uint64_t v0 = s->version();
  const auto t0 = Clock::now();
  run.startInBackground();
  EXPECT_TRUE(std::chrono::duration<double>(Clock::now() - t0).count() < 0.05); // returns at once
  // The session shows newer networks while the run goes on (several publishes before it ends).
  std::vector<uint64_t> versions;
  waitFor([&]() {
    const uint64_t v = s->version();
    if (versions.empty() || versions.back() != v)
      versions.push_back(v);
    return run.status().State == RunState::Finished;
  }, 120.0);
  EXPECT_TRUE(run.status().State == RunState::Finished);
  EXPECT_TRUE(versions.size() >= 3);
  EXPECT_TRUE(s->version() > v0);
  EXPECT_TRUE(run.status().Steps == 400);
  EXPECT_TRUE(run.status().EndReason == "step limit");
  EXPECT_TRUE(hookCalls == 1);
  EXPECT_TRUE(run.log().size() == 400);
  // Probes every 50 steps before the last: 7 PSNR values, finite and rising overall.
  int probes = 0;
  double first = 0, last = 0;
  for (const LogRow& r : run.log())
    if (std::isfinite(r.PSNR))
    {
      first = probes == 0 ? r.PSNR : first;
      last = r.PSNR;
      ++probes;
    }
  EXPECT_TRUE(probes == 7);
  EXPECT_TRUE(last > first + 3.0);
}

NV_TEST(pause_resume_continue_fast_forward_are_exact)
{
  const std::vector<float> values = analyticVolume(0.0);
  auto d = data(values, false);
  std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
  TrainingRun run(s, d, trainConfig(), limits(300), nullptr);
  run.startInBackground();
  EXPECT_TRUE(waitFor([&]() { return run.status().Steps >= 20; }, 60.0));
  run.pause();
  EXPECT_TRUE(run.status().State == RunState::Paused);
  // The step in flight completes; then nothing moves, and the session keeps its network.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const int64_t paused = run.status().Steps;
  const uint64_t version = s->version();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  EXPECT_TRUE(run.status().Steps == paused);
  EXPECT_TRUE(s->version() == version);
  EXPECT_TRUE(paused < 300);
  run.resume();
  EXPECT_TRUE(run.wait(120.0));
  EXPECT_TRUE(run.status().Steps == 300);
  run.extend(37, false);
  EXPECT_TRUE(run.wait(60.0));
  EXPECT_TRUE(run.status().Steps == 337);
  EXPECT_TRUE(run.status().State == RunState::Finished);
  const uint64_t beforeFast = s->version();
  run.extend(50, true); // fast-forward: one publish at the end
  EXPECT_TRUE(run.wait(60.0));
  EXPECT_TRUE(run.status().Steps == 387);
  EXPECT_TRUE(s->version() == beforeFast + 1);
  EXPECT_TRUE(run.log().size() == 387);
}

NV_TEST(stop_ends_within_a_fifth_of_a_second_and_publishes_nothing_after)
{
  const std::vector<float> values = analyticVolume(0.0);
  auto d = data(values, false);
  std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
  TrainingRun run(s, d, trainConfig(), limits(1000000), nullptr);
  run.startInBackground();
  EXPECT_TRUE(waitFor([&]() { return run.status().Steps >= 10; }, 60.0));
  const auto t0 = Clock::now();
  run.stop();
  EXPECT_TRUE(run.wait(5.0));
  const double latency = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf("  stop latency %.4f s\n", latency);
  EXPECT_TRUE(latency < 0.2);
  EXPECT_TRUE(run.status().State == RunState::Stopped);
  EXPECT_TRUE(run.status().EndReason == "stopped");
  const uint64_t version = s->version();
  const int64_t steps = run.status().Steps;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_TRUE(s->version() == version);
  EXPECT_TRUE(run.status().Steps == steps);
  // Not sticky: a new phase trains again.
  run.extend(5, false);
  EXPECT_TRUE(run.wait(30.0));
  EXPECT_TRUE(run.status().Steps == steps + 5);
  EXPECT_TRUE(run.status().State == RunState::Finished);
}

NV_TEST(abort_in_the_calling_thread_is_not_sticky)
{
  const std::vector<float> values = analyticVolume(0.0);
  auto d = data(values, false);
  std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
  TrainingRun run(s, d, trainConfig(), limits(100), nullptr);
  int polls = 0;
  run.runHere([&]() { return ++polls > 10; }, nullptr);
  EXPECT_TRUE(run.status().State == RunState::Stopped);
  EXPECT_TRUE(run.status().Steps == 10);
  run.extend(20, false); // runs here again, without an abort
  EXPECT_TRUE(run.status().Steps == 30);
  EXPECT_TRUE(run.status().State == RunState::Finished);
}

NV_TEST(target_psnr_and_time_budget_end_the_phase)
{
  const std::vector<float> values = analyticVolume(0.0);
  {
    auto d = data(values);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
    RunLimits l = limits(5000, 10);
    l.TargetPsnr = 25.0;
    TrainingRun run(s, d, trainConfig(), l, nullptr);
    run.runHere(nullptr, nullptr);
    const RunStatus st = run.status();
    EXPECT_TRUE(st.EndReason == "target PSNR");
    EXPECT_TRUE(st.Steps < 5000 && st.Steps % 10 == 0);
    EXPECT_TRUE(st.Psnr >= 25.0);
  }
  {
    auto d = data(values, false);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
    RunLimits l = limits(1000000);
    l.TimeBudget = 0.5;
    TrainingRun run(s, d, trainConfig(), l, nullptr);
    run.startInBackground();
    // Paused time does not count against the budget.
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    run.pause();
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    EXPECT_TRUE(run.status().State == RunState::Paused);
    run.resume();
    EXPECT_TRUE(run.wait(30.0));
    const RunStatus st = run.status();
    EXPECT_TRUE(st.EndReason == "time budget");
    std::printf("  budget 0.5 s: %.3f s of training, %lld steps\n", st.Seconds, static_cast<long long>(st.Steps));
    EXPECT_TRUE(st.Seconds >= 0.5 && st.Seconds < 0.75);
  }
}

NV_TEST(time_budget_keeps_time_for_the_measurement_at_the_end)
{
  // The budget bounds the run and the measurement its phase end makes (FinalSamples network evaluations at the rate
  // the probes measured): here the hook evaluates 2^19 points, as the filter measures a field of that size.
  const std::vector<float> values = analyticVolume(0.0);
  auto d = data(values);
  std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
  const int64_t points = int64_t(1) << 19;
  std::vector<float> xyz(static_cast<size_t>(3 * points)), out(static_cast<size_t>(points));
  for (size_t i = 0; i < xyz.size(); ++i)
    xyz[i] = float((i * 2654435761u) % 1000u) / 999.0f;
  double hookSeconds = 0.0;
  RunLimits l = limits(1000000, 20);
  l.TimeBudget = 1.0;
  l.FinalSamples = points;
  TrainingRun run(s, d, trainConfig(), l, [&](TrainingRun& r, const RunStatus&) {
    const auto t0 = Clock::now();
    r.session().inferPoints(xyz.data(), points, out.data());
    hookSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
  });
  const auto start = Clock::now();
  run.runHere(nullptr, nullptr);
  const double total = std::chrono::duration<double>(Clock::now() - start).count();
  const RunStatus st = run.status();
  std::printf("  budget 1 s: %.3f s of training + %.3f s measuring = %.3f s in all (reserve %.3f s)\n", st.Seconds,
    hookSeconds, total, run.finalReserveSeconds());
  EXPECT_TRUE(st.EndReason == "time budget");
  EXPECT_TRUE(run.finalReserveSeconds() > 0.0);
  EXPECT_TRUE(st.Seconds < 1.0);
  EXPECT_TRUE(total >= 0.8 && total <= 1.2);
}

NV_TEST(low_priority_workers_run_at_a_higher_niceness)
{
#if defined(__linux__)
  // TrainConfig::lowPriority: the CPU trainer's workers (not the caller's thread) leave an application its cores.
  const int callerNice = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  std::vector<int> niceness(2, -100);
  ThreadPool pool(2, true);
  pool.runOnAll([&](int worker) { niceness[size_t(worker)] = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))); });
  EXPECT_TRUE(niceness[0] == callerNice);
  EXPECT_TRUE(niceness[1] == std::max(callerNice, kLowPriorityNiceness));
  ThreadPool normal(2, false);
  normal.runOnAll([&](int worker) { niceness[size_t(worker)] = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))); });
  EXPECT_TRUE(niceness[1] == callerNice);
#endif
}

NV_TEST(annealed_schedule_ends_at_its_floor_on_the_last_step)
{
  // The default schedule (Auto) anneals over the phase after its hold: TrainingRun plans the trainer's steps, so the
  // cosine reaches 1/100 of the rate exactly at the last step; a later Continue stays at that floor. Under a time budget the plan
  // follows the measured step rate, so the last steps run near the floor too. An explicit step decay ignores plans.
  const std::vector<float> values = analyticVolume(0.0);
  const double lr = TrainConfig().optimizer.learningRate;
  auto rateAt = [&](const std::vector<LogRow>& log, int64_t step) { return log[size_t(step - 1)].LearningRate; };
  TrainConfig fromFirstStep = trainConfig();
  fromFirstStep.optimizer.holdSteps = 0; // the default holds the full rate for 500 steps: checked below
  {
    auto d = data(values, false);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
    TrainingRun run(s, d, fromFirstStep, limits(200), nullptr);
    run.runHere(nullptr, nullptr);
    run.extend(20, false);
    const std::vector<LogRow> log = run.log();
    EXPECT_TRUE(log.size() == 220);
    std::printf("  200 steps: rate %.6g at step 1, %.6g at 100, %.6g at 200, %.6g at 220 (continued)\n",
      rateAt(log, 1), rateAt(log, 100), rateAt(log, 200), rateAt(log, 220));
    EXPECT_TRUE(std::fabs(rateAt(log, 100) / lr - (0.01 + 0.99 * 0.5)) < 1e-12);
    EXPECT_TRUE(std::fabs(rateAt(log, 200) / lr - 0.01) < 1e-12);
    EXPECT_TRUE(std::fabs(rateAt(log, 220) / lr - 0.01) < 1e-12);
    EXPECT_TRUE(rateAt(log, 1) > 0.999 * lr);
  }
  {
    auto d = data(values, false);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
    TrainConfig tc = trainConfig();
    tc.optimizer.schedule = LearningRateSchedule::StepDecay;
    TrainingRun run(s, d, tc, limits(200), nullptr);
    run.runHere(nullptr, nullptr);
    EXPECT_TRUE(std::fabs(rateAt(run.log(), 200) - lr) < 1e-15);
  }
  {
    // The default: a 200-step run is shorter than the 500-step hold, so it trains at the full rate throughout; a
    // 700-step run holds 500 steps and then anneals to the floor at its last.
    auto d = data(values, false);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
    TrainingRun run(s, d, trainConfig(), limits(200), nullptr);
    run.runHere(nullptr, nullptr);
    for (int64_t step : { 1, 100, 200 })
      EXPECT_TRUE(std::fabs(rateAt(run.log(), step) - lr) < 1e-15);
    auto d2 = data(values, false);
    std::shared_ptr<NetworkSession> s2 = nvtest::session(model(*d2, 1), Device::Cpu, 2);
    TrainingRun longer(s2, d2, trainConfig(), limits(700), nullptr);
    longer.runHere(nullptr, nullptr);
    EXPECT_TRUE(std::fabs(rateAt(longer.log(), 500) - lr) < 1e-15);
    EXPECT_TRUE(std::fabs(rateAt(longer.log(), 600) / lr - (0.01 + 0.99 * 0.5)) < 1e-12);
    EXPECT_TRUE(std::fabs(rateAt(longer.log(), 700) / lr - 0.01) < 1e-12);
  }
  {
    auto d = data(values, false);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 1), Device::Cpu, 2);
    RunLimits l = limits(1000000);
    l.TimeBudget = 0.5;
    TrainingRun run(s, d, fromFirstStep, l, nullptr);
    run.runHere(nullptr, nullptr);
    const std::vector<LogRow> log = run.log();
    const double last = log.back().LearningRate / lr, first = log.front().LearningRate / lr;
    std::printf("  0.5 s budget: %zu steps, rate %.4g x lr at the first step, %.4g x lr at the last\n", log.size(),
      first, last);
    EXPECT_TRUE(log.size() > 20 && first > 0.99 && last < 0.1);
  }
}

NV_TEST(same_seed_and_steps_give_the_same_network_bit_for_bit)
{
  const std::vector<float> values = analyticVolume(0.0);
  std::vector<std::vector<float>> params;
  for (int k = 0; k < 3; ++k)
  {
    auto d = data(values, k == 2);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 3), Device::Cpu, 2);
    RunLimits l = limits(120, k == 2 ? 20 : 0);
    l.KeepBest = false; // probes only watch here (KeepBestNetwork is tested below)
    TrainingRun run(s, d, trainConfig(), l, nullptr);
    if (k == 0)
      run.runHere(nullptr, nullptr);
    else
    {
      // In the background, with publishes (and probes for k == 2) in between: they do not change the training.
      run.startInBackground();
      EXPECT_TRUE(run.wait(120.0));
    }
    params.push_back(s->currentModel().params());
  }
  EXPECT_TRUE(params[0] == params[1]);
  EXPECT_TRUE(params[0] == params[2]);
  // A different seed is a different network (the comparison can fail).
  auto d = data(values, false);
  std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 4), Device::Cpu, 2);
  TrainingRun run(s, d, trainConfig(), limits(120), nullptr);
  run.runHere(nullptr, nullptr);
  EXPECT_TRUE(s->currentModel().params() != params[0]);
}

NV_TEST(warm_start_reaches_the_cold_psnr_in_fewer_steps)
{
  // Time step t trained; t+1 is the same field moved a little (a flow advancing).
  const std::vector<float> t0 = analyticVolume(0.0), t1 = analyticVolume(0.15);
  auto d0 = data(t0, false);
  std::shared_ptr<NetworkSession> s0 = nvtest::session(model(*d0, 1), Device::Cpu, 2);
  TrainingRun first(s0, d0, trainConfig(), limits(400), nullptr);
  first.runHere(nullptr, nullptr);

  const int steps = 100;
  auto cold = data(t1, false), warm = data(t1, false);
  std::shared_ptr<NetworkSession> sc = nvtest::session(model(*cold, 1), Device::Cpu, 2);
  Model seeded = model(*warm, 1);
  seeded.params() = s0->currentModel().params();
  std::shared_ptr<NetworkSession> sw = nvtest::session(seeded, Device::Cpu, 2);
  const double warmAtStart = psnrOf(*sw, warm->Field.View);
  TrainingRun coldRun(sc, cold, trainConfig(), limits(steps), nullptr);
  TrainingRun warmRun(sw, warm, trainConfig(), limits(steps), nullptr);
  coldRun.runHere(nullptr, nullptr);
  warmRun.runHere(nullptr, nullptr);
  const double coldPsnr = psnrOf(*sc, cold->Field.View), warmPsnr = psnrOf(*sw, warm->Field.View);
  std::printf("  after %d steps: cold %.2f dB, warm %.2f dB (warm before training %.2f dB)\n", steps, coldPsnr,
    warmPsnr, warmAtStart);
  EXPECT_TRUE(warmPsnr > coldPsnr + 2.0);
  EXPECT_TRUE(warmAtStart > coldPsnr - 10.0); // the previous network is already a fair picture of t+1
}

NV_TEST(non_finite_loss_rolls_back_and_lowers_the_learning_rate)
{
  // Learning rate 1e6: the loss explodes at step 2. The run rolls back to its last good network, lowers the learning
  // rate 10x each time (measured: 6 times, to 1) and goes on; it ends with a finite network, a finite (honest, here
  // poor: 5.3 dB) PSNR and a log without a diverged loss, and says what it did.
  const std::vector<float> values = analyticVolume(0.0);
  auto d = data(values, true);
  std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 3), Device::Cpu, 2);
  TrainConfig tc = trainConfig();
  tc.optimizer.learningRate = 1e6;
  TrainingRun run(s, d, tc, limits(300, 20), nullptr);
  run.runHere(nullptr, nullptr);
  const RunStatus st = run.status();
  std::printf("  state %s, %lld steps, %zu warnings%s%s\n", runStateName(st.State), (long long)st.Steps,
    st.Warnings.size(), st.Warnings.empty() ? "" : "; last: ", st.Warnings.empty() ? "" : st.Warnings.back().c_str());
  EXPECT_TRUE(st.State == RunState::Finished);
  EXPECT_TRUE(st.Steps == 300);
  EXPECT_TRUE(!st.Warnings.empty() && st.Warnings.front().find("rolled back") != std::string::npos);
  bool finite = true;
  const Model current = s->currentModel(); // held: a range-for over a temporary's member reads freed memory
  for (float p : current.params())
    finite = finite && std::isfinite(p);
  EXPECT_TRUE(finite);
  for (const LogRow& r : run.log())
    EXPECT_TRUE(std::isfinite(r.Loss) && r.Loss <= 1e3);
  EXPECT_TRUE(run.log().size() == 300);
  const double psnr = psnrOf(*s, d->Field.View);
  std::printf("  final PSNR %.2f dB\n", psnr);
  EXPECT_TRUE(std::isfinite(psnr) && psnr > 0.0);
  EXPECT_TRUE(st.Warnings.size() >= 2 && st.Warnings.size() <= 10); // several 10x cuts, within the limit
}

NV_TEST(keeps_the_best_probed_network)
{
  // L2 at a constant learning rate of 0.05 climbs and then wanders: the run keeps the network of its best probe
  // (the phase's final PSNR estimate is never more than 0.1 dB below the best in its log), and without KeepBest the
  // last network is returned as it is.
  const std::vector<float> values = analyticVolume(0.0);
  TrainConfig tc = trainConfig();
  tc.loss = LossType::L2;
  tc.optimizer.learningRate = 0.05;
  tc.optimizer.stepDecay = false;
  double finals[2] = { 0, 0 }, bestInLog[2] = { 0, 0 };
  size_t notes[2] = { 0, 0 };
  for (int keep = 0; keep < 2; ++keep)
  {
    auto d = data(values, true);
    std::shared_ptr<NetworkSession> s = nvtest::session(model(*d, 5), Device::Cpu, 2);
    RunLimits l = limits(400, 10);
    l.KeepBest = keep == 1;
    TrainingRun run(s, d, tc, l, nullptr);
    run.runHere(nullptr, nullptr);
    bestInLog[keep] = -1e30;
    for (const LogRow& r : run.log())
      if (std::isfinite(r.PSNR))
        bestInLog[keep] = std::max(bestInLog[keep], r.PSNR);
    finals[keep] = d->Probe->estimate(*s);
    notes[keep] = run.status().Notes.size();
    EXPECT_TRUE(run.status().Warnings.empty()); // keeping the best network is no warning
    std::printf("  KeepBest %d: best probe %.2f dB, final estimate %.2f dB, notes %zu%s%s\n", keep, bestInLog[keep],
      finals[keep], notes[keep], notes[keep] ? ": " : "", notes[keep] ? run.status().Notes.back().c_str() : "");
  }
  EXPECT_TRUE(finals[1] >= bestInLog[1] - 0.1);
  EXPECT_TRUE(finals[1] >= finals[0] - 1e-9);
  EXPECT_TRUE(notes[0] == 0);
  EXPECT_TRUE((notes[1] == 1) == (finals[1] > finals[0] + 1e-9)); // a note exactly when the network was replaced
}

int main(int argc, char** argv)
{
  return nvtest::runCases(argc, argv);
}
