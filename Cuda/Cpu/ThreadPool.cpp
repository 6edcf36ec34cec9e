#include "ThreadPool.h"

#include "Core/EngineWarnings.h"
#include "Core/ThreadPriority.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <string>
#if defined(__SSE__) || defined(_M_X64)
#include <xmmintrin.h>
#define NV_HAVE_MXCSR 1
#endif

namespace nv
{

int ThreadPool::defaultThreads()
{
  const unsigned n = std::thread::hardware_concurrency();
  return n == 0 ? 1 : static_cast<int>(n);
}

int ThreadPool::usableThreads(int threads, std::string* warning)
{
  const int hardware = defaultThreads();
  if (threads <= 0)
    return hardware;
  const int most = hardware > std::numeric_limits<int>::max() / kMaxThreadsPerCore ? std::numeric_limits<int>::max()
                                                                                    : hardware * kMaxThreadsPerCore;
  if (threads <= most)
    return threads;
  if (warning)
    *warning = "Threads " + std::to_string(threads) + " is more than " + std::to_string(kMaxThreadsPerCore) +
      " x the " + std::to_string(hardware) + " hardware threads: " + std::to_string(most) + " threads are used";
  return most;
}

ThreadPool::ThreadPool(int threads, bool lowPriority)
  : LowPriority(lowPriority)
{
  std::string capped;
  Count = usableThreads(threads, &capped);
  if (!capped.empty())
    postWarning(capped);
  const int asked = Count;
  for (int i = 1; i < asked; ++i)
  {
    try
    {
      Workers.emplace_back([this, i, lowPriority] {
        if (lowPriority)
          lowerCurrentThreadPriority();
        workerLoop(i);
      });
    }
    catch (const std::exception& e) // std::system_error (EAGAIN), or std::bad_alloc for the thread's state
    {
      // Go on with the workers created so far: runOnAll waits for exactly Count - 1 of them.
      Count = i;
      postWarning("could create only " + std::to_string(i) + " of " + std::to_string(asked) +
        " threads (" + e.what() + "): the work runs on " + std::to_string(i) + (i == 1 ? " thread" : " threads"));
      break;
    }
  }
}

ThreadPool::~ThreadPool()
{
  {
    std::lock_guard<std::mutex> lock(Mutex);
    Stop = true;
  }
  Wake.notify_all();
  for (auto& t : Workers)
  {
    t.join();
  }
}

namespace
{
// Flush denormals to zero while engine work runs: Adam's moments of rarely touched table entries decay
// geometrically into the denormal range after ~700 steps, which slows x86 arithmetic by orders of magnitude.
// The CUDA engine (fast math) flushes them as well.
class DenormalsAreZero
{
public:
  DenormalsAreZero()
  {
#if defined(NV_HAVE_MXCSR)
    Saved = _mm_getcsr();
    _mm_setcsr(Saved | 0x8040u); // FTZ | DAZ
#endif
  }
  ~DenormalsAreZero()
  {
#if defined(NV_HAVE_MXCSR)
    _mm_setcsr(Saved);
#endif
  }

private:
  unsigned Saved = 0;
};
} // namespace

void ThreadPool::workerLoop(int id)
{
  DenormalsAreZero ftz;
  uint64_t seen = 0;
  for (;;)
  {
    const std::function<void(int)>* job;
    {
      std::unique_lock<std::mutex> lock(Mutex);
      Wake.wait(lock, [&] { return Stop || Generation != seen; });
      if (Stop)
      {
        return;
      }
      seen = Generation;
      job = Job;
    }
    try
    {
      (*job)(id);
    }
    catch (...)
    {
      std::lock_guard<std::mutex> lock(Mutex);
      if (!Failure)
      {
        Failure = std::current_exception();
      }
    }
    {
      std::lock_guard<std::mutex> lock(Mutex);
      if (--Pending == 0)
      {
        Done.notify_all();
      }
    }
  }
}

void ThreadPool::runOnAll(const std::function<void(int)>& fn)
{
  DenormalsAreZero ftz;
  if (Count == 1)
  {
    fn(0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(Mutex);
    Job = &fn;
    Pending = Count - 1;
    Failure = nullptr;
    ++Generation;
  }
  Wake.notify_all();
  std::exception_ptr mine;
  try
  {
    fn(0);
  }
  catch (...)
  {
    mine = std::current_exception();
  }
  std::unique_lock<std::mutex> lock(Mutex);
  Done.wait(lock, [&] { return Pending == 0; });
  Job = nullptr;
  if (mine)
  {
    std::rethrow_exception(mine);
  }
  if (Failure)
  {
    std::rethrow_exception(Failure);
  }
}

void ThreadPool::parallelFor(int64_t n, const std::function<void(int64_t, int64_t, int)>& fn)
{
  if (n <= 0)
  {
    return;
  }
  const int64_t parts = std::min<int64_t>(Count, n);
  runOnAll([&](int w) {
    if (w >= parts)
    {
      return;
    }
    const int64_t b = n * w / parts;
    const int64_t e = n * (w + 1) / parts;
    fn(b, e, w);
  });
}

void ThreadPool::parallelChunks(int64_t n, int64_t chunk, const std::function<void(int64_t, int64_t, int)>& fn)
{
  if (n <= 0)
  {
    return;
  }
  std::atomic<int64_t> next(0);
  runOnAll([&](int w) {
    for (;;)
    {
      const int64_t b = next.fetch_add(chunk);
      if (b >= n)
      {
        return;
      }
      fn(b, std::min(n, b + chunk), w);
    }
  });
}

} // namespace nv
