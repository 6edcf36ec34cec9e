// The Neural Volume mapper's background renderer (Representations/vtkNeuralProgressiveRenderer, VTK-free) against a
// scripted session, for issue 29 ("never crash"): its worker thread never sees a half-constructed renderer (the GUI
// thread may be preempted right after creating the thread: modelled here by a delay injected into pthread_create and
// a renderer constructed in memory full of garbage); a renderer destroyed in the middle of a render has stopped
// rendering when its destructor returns; jobs replaced, cancelled and destroyed in quick succession always hand the
// session a request whose depth buffer covers the image, and the last job of each burst publishes its final image.
#include "TestHarness.h"

#include "vtkNeuralProgressiveRenderer.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <dlfcn.h>
#include <new>
#include <pthread.h>
#include <random>
#include <stdexcept>
#include <thread>
#include <unistd.h>

using Clock = std::chrono::steady_clock;

// A sanitizer runtime owns pthread_create (Clang links it into the executable): no interposition there.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define NV_INTERPOSE_PTHREAD_CREATE 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define NV_INTERPOSE_PTHREAD_CREATE 0
#endif
#endif
#ifndef NV_INTERPOSE_PTHREAD_CREATE
#define NV_INTERPOSE_PTHREAD_CREATE 1
#endif

namespace
{
/// Microseconds the thread that calls pthread_create sleeps once the new thread runs (0: none).
std::atomic<int> creatorDelayMicroseconds{ 0 };
} // namespace

#if NV_INTERPOSE_PTHREAD_CREATE
/// Interposes the C library's pthread_create (std::thread calls it): with creatorDelayMicroseconds set, the creating
/// thread stalls after the new thread started, as a GUI thread preempted at that point on a loaded machine does.
extern "C" int pthread_create(
  pthread_t* thread, const pthread_attr_t* attributes, void* (*start)(void*), void* argument)
{
  using Create = int (*)(pthread_t*, const pthread_attr_t*, void* (*)(void*), void*);
  static const Create next = reinterpret_cast<Create>(dlsym(RTLD_NEXT, "pthread_create"));
  const int result = next(thread, attributes, start, argument);
  if (const int delay = creatorDelayMicroseconds.load())
    usleep(static_cast<useconds_t>(delay));
  return result;
}
#endif

namespace
{
/// A session that only renders: a flat image after `renderMilliseconds` (cancellable like the CPU engine), checking
/// that every request's depth buffer holds width*height entries of kDepth.
class ScriptedSession final : public nv::NetworkSession
{
public:
  static constexpr float kDepth = 0.25f;
  std::atomic<int> RenderMilliseconds{ 0 };
  std::atomic<int> InFlight{ 0 };
  std::atomic<int> Renders{ 0 };
  std::atomic<int> BadRequests{ 0 };

  nv::Device device() const override { return nv::Device::Cpu; }
  const nv::Model& model() const override { throw std::logic_error("not scripted"); }
  uint64_t version() const override { return 1; }
  void setModel(const nv::Model&) override {}
  void syncModel() override {}
  nv::Model currentModel() override { throw std::logic_error("not scripted"); }
  std::unique_ptr<nv::Trainer> createTrainer(const nv::VolumeView&, const nv::TrainConfig&) override { return nullptr; }
  std::unique_ptr<nv::Trainer> createTrainer(nv::BatchSource&, const nv::TrainConfig&) override { return nullptr; }
  std::unique_ptr<nv::Trainer> createTrainer(const nv::TrainingPoints&, const nv::TrainConfig&) override
  {
    return nullptr;
  }
  void inferPoints(const float*, int64_t, float*, nv::Memory) override {}
  void decodeGrid(int64_t, int64_t, int64_t, int64_t, int64_t, float*, nv::Memory) override {}
  bool workPending() const override { return false; }
  int64_t deviceMemoryBytes() const override { return 0; }

  void render(const nv::RenderRequest& q, nv::RenderResult& result, nv::Memory) override
  {
    ++this->InFlight;
    ++this->Renders;
    const size_t pixels = static_cast<size_t>(q.width) * static_cast<size_t>(q.height);
    // Every entry is read, so an AddressSanitizer build also sees a buffer shorter than the image.
    if (q.depth && !(q.depth[0] == kDepth && q.depth[pixels - 1] == kDepth))
      ++this->BadRequests;
    if (!q.control)
      ++this->BadRequests;
    const Clock::time_point end = Clock::now() + std::chrono::milliseconds(this->RenderMilliseconds.load());
    result = nv::RenderResult();
    while (Clock::now() < end && !(q.control && q.control->cancel.load()))
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    result.stats.cancelled = q.control && q.control->cancel.load();
    if (!result.stats.cancelled)
    {
      result.rgba.assign(pixels * 4, 0.5f);
      result.stats.rays = static_cast<int64_t>(pixels);
      result.stats.renderMilliseconds = 0.01 * static_cast<double>(pixels);
    }
    --this->InFlight;
  }
};

vtkNeuralProgressiveRenderer::Job makeJob(
  const std::shared_ptr<ScriptedSession>& session, int width, int height, uint64_t key, bool depth)
{
  vtkNeuralProgressiveRenderer::Job job;
  job.Session = session;
  job.Request.width = width;
  job.Request.height = height;
  job.Request.path = nv::RenderPath::SampleStreaming;
  job.Key = key;
  job.SceneKey = key;
  job.BudgetMilliseconds = 5.0;
  if (depth)
    job.Depth.assign(static_cast<size_t>(width) * static_cast<size_t>(height), ScriptedSession::kDepth);
  return job;
}

/// Takes images of the current job until its final one (true), or false after `seconds`.
bool waitForFinalImage(vtkNeuralProgressiveRenderer& renderer, double seconds, vtkNeuralProgressiveRenderer::Image& last)
{
  const Clock::time_point end =
    Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  while (Clock::now() < end)
  {
    vtkNeuralProgressiveRenderer::Image image;
    if (renderer.WaitForImage(20.0) && renderer.TakeImage(image))
    {
      last = std::move(image);
      if (last.Final)
        return true;
    }
  }
  return false;
}

/// Waits at most `seconds` for the renderer to end its job (it publishes the final image a moment before).
bool waitUntilIdle(vtkNeuralProgressiveRenderer& renderer, double seconds)
{
  const Clock::time_point end =
    Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  while (renderer.Busy() && Clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return !renderer.Busy();
}
} // namespace

NV_TEST(the_worker_never_sees_a_half_constructed_renderer)
{
  // Issue 29: the worker used to start in a member initializer, before the members declared after it existed. A
  // GUI thread preempted right after creating it left the worker reading garbage: here every byte is 0xFF, so it
  // read Stopping as set and quit (the view never refined); other garbage made it run a garbage job (SIGSEGV in Run).
  if (!NV_INTERPOSE_PTHREAD_CREATE)
    std::printf("  (sanitizer build: pthread_create is not interposed, the creating thread does not stall)\n");
  auto session = std::make_shared<ScriptedSession>();
  for (int round = 0; round < 3; ++round)
  {
    alignas(vtkNeuralProgressiveRenderer) unsigned char memory[sizeof(vtkNeuralProgressiveRenderer)];
    std::memset(memory, 0xFF, sizeof(memory));
    creatorDelayMicroseconds = 30000;
    auto* renderer = new (memory) vtkNeuralProgressiveRenderer;
    creatorDelayMicroseconds = 0;
    renderer->Start(makeJob(session, 64, 48, 7, true));
    vtkNeuralProgressiveRenderer::Image image;
    const bool finished = waitForFinalImage(*renderer, 10.0, image);
    EXPECT_TRUE(finished);
    EXPECT_TRUE(!finished || (image.Width == 64 && image.Height == 48 && image.Key == 7));
    EXPECT_TRUE(waitUntilIdle(*renderer, 5.0));
    renderer->~vtkNeuralProgressiveRenderer();
  }
  EXPECT_TRUE(session->BadRequests.load() == 0);
}

NV_TEST(a_renderer_destroyed_mid_render_has_stopped_rendering)
{
  // The mapper's Internals destroy the renderer before the session and the compositor: nothing may still render.
  auto session = std::make_shared<ScriptedSession>();
  session->RenderMilliseconds = 2000;
  for (int round = 0; round < 5; ++round)
  {
    const int rendersBefore = session->Renders.load();
    auto renderer = std::unique_ptr<vtkNeuralProgressiveRenderer>(new vtkNeuralProgressiveRenderer);
    renderer->Start(makeJob(session, 200, 100, 11, true));
    const Clock::time_point waitEnd = Clock::now() + std::chrono::seconds(5);
    while (session->Renders.load() == rendersBefore && Clock::now() < waitEnd)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    EXPECT_TRUE(session->InFlight.load() == 1);
    const Clock::time_point destroyed = Clock::now();
    renderer.reset();
    EXPECT_TRUE(session->InFlight.load() == 0);
    EXPECT_TRUE(Clock::now() - destroyed < std::chrono::milliseconds(1000)); // cancelled, not waited for
  }
  EXPECT_TRUE(session->BadRequests.load() == 0);
}

NV_TEST(jobs_replaced_cancelled_and_destroyed_in_bursts)
{
  // A camera drag: a new job every few milliseconds of random size, some cancelled, the renderer itself replaced
  // now and then (a representation removed and shown again); the last job of each burst must still finish.
  auto session = std::make_shared<ScriptedSession>();
  session->RenderMilliseconds = 1;
  std::mt19937 random(29);
  std::unique_ptr<vtkNeuralProgressiveRenderer> renderer(new vtkNeuralProgressiveRenderer);
  uint64_t key = 100;
  int finished = 0;
  const int bursts = 40;
  for (int burst = 0; burst < bursts; ++burst)
  {
    if (burst % 7 == 6)
      renderer.reset(new vtkNeuralProgressiveRenderer);
    int width = 0, height = 0;
    for (int k = 0; k < 12; ++k)
    {
      width = 1 + static_cast<int>(random() % 300);
      height = 1 + static_cast<int>(random() % 200);
      renderer->Start(makeJob(session, width, height, ++key, random() % 2 == 0));
      if (random() % 4 == 0)
        renderer->Cancel();
      std::this_thread::sleep_for(std::chrono::microseconds(random() % 3000));
    }
    renderer->Start(makeJob(session, width, height, ++key, true));
    vtkNeuralProgressiveRenderer::Image image;
    if (waitForFinalImage(*renderer, 10.0, image) && image.Width == width && image.Height == height &&
      image.Key == key && image.Rgba.size() == static_cast<size_t>(width) * static_cast<size_t>(height) * 4)
      ++finished;
    EXPECT_TRUE(renderer->TakeError().empty());
  }
  renderer.reset();
  std::printf("  %d of %d bursts finished their last job (%d engine renders)\n", finished, bursts,
    session->Renders.load());
  EXPECT_TRUE(finished == bursts);
  EXPECT_TRUE(session->InFlight.load() == 0);
  EXPECT_TRUE(session->BadRequests.load() == 0);
}

NV_TEST_MAIN()
