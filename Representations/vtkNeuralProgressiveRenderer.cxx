#include "vtkNeuralProgressiveRenderer.h"

#include "Core/ThreadPriority.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <new>
#include <stdexcept>

namespace
{
/// Engine milliseconds per ray assumed before any render of that kind was measured (2 cores: Sample Streaming ray
/// marching ~0.01, In-Shader with shadows ~0.4); the first image then measures it.
constexpr double kGuessMillisecondsPerRay = 0.05;
/// The first image is at least 2^-kMaxReductions of the final size per axis.
constexpr int kMaxReductions = 6;
/// The Decode path: how often the worker looks whether the background decode has the full grid.
constexpr std::chrono::milliseconds kDecodePoll(20);

int ModeOf(const nv::RenderRequest& q)
{
  return static_cast<int>(q.path) * 16 + static_cast<int>(q.shading);
}

int Scaled(int size, double scale)
{
  return std::max(1, static_cast<int>(std::lround(size * scale)));
}

/// Nearest resampling of width x height depths to w x h (row 0 at the bottom).
void ResampleDepth(const std::vector<float>& depth, int width, int height, int w, int h, std::vector<float>& out)
{
  out.resize(static_cast<size_t>(w) * static_cast<size_t>(h));
  for (int y = 0; y < h; ++y)
  {
    const int sy = std::min(height - 1, static_cast<int>((y + 0.5) * height / h));
    for (int x = 0; x < w; ++x)
    {
      const int sx = std::min(width - 1, static_cast<int>((x + 0.5) * width / w));
      out[static_cast<size_t>(y) * w + x] = depth[static_cast<size_t>(sy) * width + sx];
    }
  }
}
} // namespace

vtkNeuralProgressiveRenderer::vtkNeuralProgressiveRenderer()
{
  // Here, not in a member initializer: a worker started there could run before the members declared after it are
  // constructed and read garbage (issue 29: a GUI thread preempted right after creating the thread).
  this->Worker = std::thread([this] { this->Run(); });
}

vtkNeuralProgressiveRenderer::~vtkNeuralProgressiveRenderer()
{
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->Stopping = true;
    if (this->Control)
    {
      this->Control->cancel = true;
    }
  }
  this->Wake.notify_all();
  this->Worker.join();
}

//------------------------------------------------------------------------------
void vtkNeuralProgressiveRenderer::AbandonInFlight()
{
  if (this->Running && this->Control)
  {
    this->Control->cancel = true;
    this->CancelTime = Clock::now();
    this->CancelPending = true;
    ++this->AbandonedJobCount;
  }
}

void vtkNeuralProgressiveRenderer::Start(Job&& job)
{
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->AbandonInFlight();
    this->Next = std::move(job);
    this->HaveNext = true;
    ++this->Serial;
    this->Key = this->Next.Key;
    this->SceneKey = this->Next.SceneKey;
    this->Running = true;
    this->Started = Clock::now();
    this->Control = std::make_shared<nv::RenderControl>();
    this->TotalRays = 1;
    this->LatestFresh = false;
    this->Error.clear();
  }
  this->Wake.notify_all();
}

void vtkNeuralProgressiveRenderer::Cancel()
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->AbandonInFlight();
  this->HaveNext = false;
  ++this->Serial;
  this->Key = 0;
  this->SceneKey = 0;
  this->Running = false;
  this->LatestFresh = false;
  this->Published.notify_all();
}

uint64_t vtkNeuralProgressiveRenderer::CurrentSceneKey() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->SceneKey;
}

uint64_t vtkNeuralProgressiveRenderer::CurrentKey() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->Key;
}

bool vtkNeuralProgressiveRenderer::WaitForImage(double milliseconds)
{
  std::unique_lock<std::mutex> lock(this->Mutex);
  this->Published.wait_for(lock, std::chrono::duration<double, std::milli>(std::max(0.0, milliseconds)),
    [this] { return this->LatestFresh || !this->Running; });
  return this->LatestFresh;
}

bool vtkNeuralProgressiveRenderer::TakeImage(Image& image)
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (!this->LatestFresh)
  {
    return false;
  }
  image = std::move(this->Latest);
  this->Latest = Image();
  this->LatestFresh = false;
  return true;
}

std::string vtkNeuralProgressiveRenderer::TakeError()
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  std::string error;
  error.swap(this->Error);
  return error;
}

bool vtkNeuralProgressiveRenderer::Busy() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->Running;
}

double vtkNeuralProgressiveRenderer::Progress() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (!this->Running)
  {
    return 1.0;
  }
  const int64_t done = this->Control ? this->Control->raysFinished.load() : 0;
  return std::min(1.0, static_cast<double>(done) / static_cast<double>(std::max<int64_t>(1, this->TotalRays)));
}

double vtkNeuralProgressiveRenderer::BusySeconds() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->Running ? std::chrono::duration<double>(Clock::now() - this->Started).count() : 0.0;
}

bool vtkNeuralProgressiveRenderer::RestedAfterLastJob(double shareOfTime) const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  const double since = std::chrono::duration<double>(Clock::now() - this->LastJobEnd).count();
  return this->LastJobSeconds <= 0.0 || since * shareOfTime >= this->LastJobSeconds * (1.0 - shareOfTime);
}

//------------------------------------------------------------------------------
void vtkNeuralProgressiveRenderer::Run()
{
  // Refining shares the cores with a training run (both below the GUI thread, which draws what they make).
  nv::lowerCurrentThreadPriority();
  std::unique_lock<std::mutex> lock(this->Mutex);
  for (;;)
  {
    this->Wake.wait(lock, [this] { return this->Stopping || this->HaveNext; });
    if (this->Stopping)
    {
      return;
    }
    const Job job = std::move(this->Next);
    this->Next = Job();
    this->HaveNext = false;
    const uint64_t serial = this->Serial;
    const std::shared_ptr<nv::RenderControl> control = this->Control;
    lock.unlock();
    std::string error;
    try
    {
      this->RunJob(job, serial, *control);
    }
    catch (const std::bad_alloc&)
    {
      error = "rendering failed: out of memory (lower DecodeResolution or the view's size)";
    }
    catch (const std::exception& e)
    {
      error = std::string("rendering failed: ") + e.what();
    }
    catch (...)
    {
      error = "rendering failed (unexpected error)";
    }
    lock.lock();
    if (serial == this->Serial)
    {
      this->Running = false;
      this->LastJobSeconds = std::chrono::duration<double>(Clock::now() - this->Started).count();
      this->LastJobEnd = Clock::now();
      if (!error.empty())
      {
        this->Error = error;
      }
    }
    this->Published.notify_all();
  }
}

double vtkNeuralProgressiveRenderer::CostPerRay(const nv::RenderRequest& request) const
{
  auto it = this->MillisecondsPerRay.find(ModeOf(request));
  return it != this->MillisecondsPerRay.end() ? it->second : kGuessMillisecondsPerRay;
}

void vtkNeuralProgressiveRenderer::RunJob(const Job& job, uint64_t serial, nv::RenderControl& control)
{
  const nv::RenderRequest& q = job.Request;
  const bool pathTracing = q.shading == nv::ShadingMode::PathTrace || q.shading == nv::ShadingMode::PathTraceNee;
  const int64_t raysPerPixel = pathTracing ? std::max(1, q.samplesPerPixel) : 1;
  const int64_t finalRays = static_cast<int64_t>(q.width) * q.height * raysPerPixel;

  // The first image: the largest 2^-k of the final size per axis that fits the budget at the measured cost.
  const double fit = std::sqrt(job.BudgetMilliseconds / (this->CostPerRay(q) * static_cast<double>(finalRays)));
  int reductions = 0;
  while (reductions < kMaxReductions && std::ldexp(1.0, -reductions) > fit)
  {
    ++reductions;
  }
  const int levels = reductions + 1;
  int64_t total = finalRays * std::max(1, job.Frames);
  for (int k = 1; k <= reductions; ++k)
  {
    total += static_cast<int64_t>(Scaled(q.width, std::ldexp(1.0, -k))) * Scaled(q.height, std::ldexp(1.0, -k)) *
      raysPerPixel;
  }
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    if (serial == this->Serial)
    {
      this->TotalRays = total;
    }
  }

  std::vector<float> depth;
  nv::RenderResult result;
  for (int level = 0; level < levels; ++level)
  {
    const double scale = std::ldexp(1.0, level - reductions);
    const bool finalSize = level == levels - 1;
    if (!this->RenderLevel(job, scale, control, depth, result))
    {
      return;
    }
    const bool more = finalSize && (result.stats.decodePending || job.Frames > 1);
    this->Publish(serial, result, q, scale, level, levels, finalSize && !more);
  }
  // The Decode path: show the final size again once the full grid is decoded (a render meanwhile reuses the image).
  while (result.stats.decodePending && job.Session->workPending())
  {
    std::this_thread::sleep_for(kDecodePoll);
    if (!this->RenderLevel(job, 1.0, control, depth, result))
    {
      return;
    }
    if (!result.stats.reused)
    {
      this->Publish(serial, result, q, 1.0, levels - 1, levels, !result.stats.decodePending && job.Frames <= 1);
    }
  }
  // Path tracing: more frames into the average at the final size.
  for (int frame = 1; frame < job.Frames; ++frame)
  {
    if (!this->RenderLevel(job, 1.0, control, depth, result))
    {
      return;
    }
    this->Publish(serial, result, q, 1.0, levels - 1, levels, frame == job.Frames - 1);
  }
}

bool vtkNeuralProgressiveRenderer::RenderLevel(const Job& job, double scale, nv::RenderControl& control,
  std::vector<float>& depth, nv::RenderResult& result)
{
  if (control.cancel.load())
  {
    this->NoteCancelled();
    return false;
  }
  nv::RenderRequest q = job.Request;
  q.width = Scaled(job.Request.width, scale);
  q.height = Scaled(job.Request.height, scale);
  q.control = &control;
  q.depth = nullptr;
  if (!job.Depth.empty())
  {
    if (q.width == job.Request.width && q.height == job.Request.height)
    {
      q.depth = job.Depth.data();
    }
    else
    {
      ResampleDepth(job.Depth, job.Request.width, job.Request.height, q.width, q.height, depth);
      q.depth = depth.data();
    }
  }
  job.Session->render(q, result);
  if (result.stats.cancelled)
  {
    ++this->CancelledRenderCount;
    this->NoteCancelled();
    return false;
  }
  const size_t expected = static_cast<size_t>(q.width) * static_cast<size_t>(q.height) * 4;
  if (result.rgba.size() != expected)
  {
    throw std::runtime_error("the engine returned an image of the wrong size");
  }
  if (!result.stats.reused)
  {
    ++this->EngineRenderCount;
    if (result.stats.rays > 0 && result.stats.renderMilliseconds > 0.0)
    {
      this->MillisecondsPerRay[ModeOf(q)] =
        result.stats.renderMilliseconds / static_cast<double>(result.stats.rays);
    }
  }
  return true;
}

void vtkNeuralProgressiveRenderer::NoteCancelled()
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (this->CancelPending)
  {
    this->AbandonMilliseconds =
      std::chrono::duration<double, std::milli>(Clock::now() - this->CancelTime).count();
    this->CancelPending = false;
  }
}

void vtkNeuralProgressiveRenderer::Publish(uint64_t serial, nv::RenderResult& result,
  const nv::RenderRequest& request, double scale, int level, int levels, bool last)
{
  Image image;
  image.Width = Scaled(request.width, scale);
  image.Height = Scaled(request.height, scale);
  image.Rgba = std::move(result.rgba); // the next render of the job writes a new one
  image.Scale = scale;
  image.Level = level;
  image.Levels = levels;
  image.Final = last;
  image.Stats = result.stats;
  image.Key = 0;
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (serial != this->Serial)
  {
    return;
  }
  image.Key = this->Key;
  this->Latest = std::move(image);
  this->LatestFresh = true;
  this->Published.notify_all();
}
