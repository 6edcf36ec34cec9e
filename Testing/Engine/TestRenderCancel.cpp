// The CPU renderer's cancellation and progress (nv::RenderControl): a render with a control that is never cancelled
// gives the same image bit for bit as one without, and counts every ray; a cancelled render stops early (a fraction of
// the samples, within milliseconds), caches nothing and leaves the next render of the request exact; the session
// answers version() and workPending() while a render on another thread holds it.
#include "RenderFixtures.h"
#include "TestHarness.h"

#include "Core/NetworkSession.h"

#include <chrono>
#include <cstdio>
#include <thread>

using namespace nv;
using namespace nvtest;

namespace
{
using Clock = std::chrono::steady_clock;

double millisSince(Clock::time_point t)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

ThreadPool& pool()
{
  static ThreadPool p(2);
  return p;
}

struct Scene
{
  std::vector<float> data = blobVolume(40);
  VolumeView volume = viewOf(data, 40, 40, 40);
  Model model = trainModel(volume, smallRenderConfig(), 300, 4096);
};
Scene& scene()
{
  static Scene s;
  return s;
}

const char* pathName(int p)
{
  static const char* n[] = { "Decode", "SampleStreaming", "InShader" };
  return n[p];
}

/// A render of `q` on a fresh renderer, cancelled from another thread `delay` milliseconds after it started (once a
/// ray is finished). Returns the stats; `latency` the milliseconds from the cancellation to the render's return.
RenderStats cancelledRender(RenderRequest q, double delay, double& latency)
{
  CpuRenderer r(pool());
  RenderControl control;
  q.control = &control;
  RenderResult out;
  Clock::time_point cancelledAt;
  std::atomic<bool> cancelled{ false };
  const Clock::time_point started = Clock::now();
  std::thread canceller([&] {
    while ((control.raysFinished.load() == 0 || millisSince(started) < delay) && !cancelled.load())
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    cancelledAt = Clock::now();
    control.cancel = true;
  });
  r.render(scene().model, 1, q, out);
  latency = millisSince(cancelledAt);
  cancelled = true;
  canceller.join();
  EXPECT_TRUE(out.stats.cancelled && out.rgba.empty());
  return out.stats;
}
} // namespace

NV_TEST(an_uncancelled_control_changes_nothing)
{
  // Every path x every shading mode, path tracing over two accumulated frames: identical bits, every ray counted.
  for (int path = 0; path < 3; ++path)
    for (int mode = 0; mode < 5; ++mode)
    {
      RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode(mode), 96, 72);
      q.samplesPerPixel = 2;
      q.waitForDecode = true;
      CpuRenderer plain(pool()), controlled(pool());
      RenderControl control;
      RenderResult a, b;
      for (int frame = 0; frame < 2; ++frame)
      {
        plain.render(scene().model, 1, q, a);
        RenderRequest c = q;
        c.control = &control;
        controlled.render(scene().model, 1, c, b);
      }
      const bool pathTrace = mode >= 3;
      const int64_t rays = int64_t(96) * 72 * (pathTrace ? 2 : 1) * (pathTrace ? 2 : 1); // ray marching: reused
      if (!(a.rgba == b.rgba && !b.stats.cancelled && control.raysFinished.load() == rays))
        fail(__FILE__, __LINE__, std::string(pathName(path)) + " mode " + std::to_string(mode) + ": rays counted " +
            std::to_string(control.raysFinished.load()) + " of " + std::to_string(rays) +
            (a.rgba == b.rgba ? "" : ", images differ"));
      EXPECT_TRUE(b.stats.samplesEvaluated == a.stats.samplesEvaluated);
    }
}

NV_TEST(a_cancelled_render_stops_early)
{
  // A 256 x 192 render of each path with shadows (Sample Streaming: one wavefront per K samples, sliced inference)
  // cancelled after a fifth of the time the whole render took: far fewer samples, and it returns within
  // milliseconds.
  for (int path = 0; path < 3; ++path)
  {
    RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode::RayMarchShadows, 256, 192);
    q.waitForDecode = true;
    CpuRenderer full(pool());
    RenderResult whole;
    const Clock::time_point t0 = Clock::now();
    full.render(scene().model, 1, q, whole);
    const double wholeMs = millisSince(t0);
    double latency = 0.0;
    const RenderStats s = cancelledRender(q, 0.2 * wholeMs, latency);
    std::printf("  %-16s whole %7.1f ms, %9lld samples; cancelled after %6.1f ms: %9lld samples, stopped %.2f ms "
                "after the cancellation\n",
      pathName(path), wholeMs, (long long)whole.stats.samplesEvaluated, 0.2 * wholeMs,
      (long long)s.samplesEvaluated, latency);
    EXPECT_TRUE(s.samplesEvaluated > 0 && s.samplesEvaluated < whole.stats.samplesEvaluated * 6 / 10);
    EXPECT_TRUE(latency < 100.0); // measured: well under 10 ms on 2 cores
  }
}

NV_TEST(a_cancel_set_before_the_render_does_nothing)
{
  CpuRenderer r(pool());
  RenderControl control;
  control.cancel = true;
  RenderRequest q = blobRequest(scene().model, RenderPath::InShader, ShadingMode::RayMarch, 64, 64);
  q.control = &control;
  RenderResult out;
  r.render(scene().model, 1, q, out);
  EXPECT_TRUE(out.stats.cancelled && out.rgba.empty() && out.stats.samplesEvaluated == 0);
  EXPECT_TRUE(control.raysFinished.load() == 0);
}

NV_TEST(the_render_after_a_cancelled_one_is_exact)
{
  // Ray marching: the cancelled render cached nothing (the next one traces and is exact). Path tracing: the partial
  // frame was not averaged in (the accumulation starts over: the same frames as a fresh renderer's).
  for (int mode : { 0, 4 })
  {
    RenderRequest q = blobRequest(scene().model, RenderPath::InShader, ShadingMode(mode), 128, 96);
    q.samplesPerPixel = 1;
    CpuRenderer fresh(pool()), r(pool());
    RenderResult expected1, expected2, got;
    fresh.render(scene().model, 1, q, expected1);
    fresh.render(scene().model, 1, q, expected2);

    RenderControl control;
    RenderRequest c = q;
    c.control = &control;
    if (mode == 4)
      r.render(scene().model, 1, c, got); // one frame accumulated before the cancelled one
    std::thread canceller([&] {
      while (control.raysFinished.load() < int64_t(128) * 96 * (mode == 4 ? 1 : 0) + 1000)
        std::this_thread::sleep_for(std::chrono::microseconds(100));
      control.cancel = true;
    });
    r.render(scene().model, 1, c, got);
    canceller.join();
    EXPECT_TRUE(got.stats.cancelled);
    control.cancel = false;
    r.render(scene().model, 1, c, got);
    EXPECT_TRUE(!got.stats.cancelled && !got.stats.reused && got.rgba == expected1.rgba);
    r.render(scene().model, 1, c, got);
    EXPECT_TRUE(got.rgba == (mode == 4 ? expected2.rgba : expected1.rgba));
    if (mode == 4)
      EXPECT_TRUE(got.stats.accumulatedFrames == 2);
    else
      EXPECT_TRUE(got.stats.reused);
  }
}

NV_TEST(the_session_answers_while_a_render_holds_it)
{
  // A background renderer asks the session for its version (and pending work) while a long render runs on another
  // thread: the answers do not wait for the render; the session's render is cancellable too.
  SessionOptions options;
  options.threads = 2;
  auto session = NetworkSession::create(Device::Cpu, scene().model, options);
  RenderRequest q = blobRequest(scene().model, RenderPath::InShader, ShadingMode::RayMarchShadows, 256, 192);
  RenderControl control;
  q.control = &control;
  RenderResult out;
  std::thread renderer([&] { session->render(q, out); });
  while (control.raysFinished.load() < 64)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  const Clock::time_point t0 = Clock::now();
  const uint64_t version = session->version();
  const bool pending = session->workPending();
  const double answerMs = millisSince(t0);
  const Clock::time_point cancelledAt = Clock::now();
  control.cancel = true;
  renderer.join();
  const double stopMs = millisSince(cancelledAt);
  std::printf("  version() and workPending() answered in %.3f ms during a render; the render stopped %.2f ms after "
              "the cancellation\n",
    answerMs, stopMs);
  EXPECT_TRUE(version == 1 && !pending);
  EXPECT_TRUE(answerMs < 20.0);
  EXPECT_TRUE(out.stats.cancelled && stopMs < 100.0);
}

NV_TEST_MAIN()
