// NeuralVolume engine: a small fixed-size thread pool with static work partitioning (deterministic).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace nv
{

class ThreadPool
{
public:
  /// threads <= 0: hardware concurrency; more than kMaxThreadsPerCore x the hardware threads: that many (a warning,
  /// Core/EngineWarnings.h). lowPriority: the workers run at a lower scheduling priority (Core/ThreadPriority.h;
  /// worker 0 is the caller's thread and keeps its own). A thread the system refuses (std::system_error: a process
  /// or address-space limit) ends the creation: the pool works with the threads it got, at least the caller's, and
  /// posts a warning "could create only N of M threads".
  explicit ThreadPool(int threads, bool lowPriority = false);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return Count; }
  /// Whether the workers run at a lower scheduling priority.
  bool lowPriority() const { return LowPriority; }

  /// Run fn(worker) on every worker (worker 0 is the calling thread) and wait. Exceptions are rethrown.
  void runOnAll(const std::function<void(int)>& fn);

  /// Split [0, n) into size() contiguous ranges; fn(begin, end, worker).
  void parallelFor(int64_t n, const std::function<void(int64_t, int64_t, int)>& fn);

  /// Dynamic chunks of `chunk` items; fn(begin, end, worker). Results must not depend on which worker runs a chunk.
  void parallelChunks(int64_t n, int64_t chunk, const std::function<void(int64_t, int64_t, int)>& fn);

  static int defaultThreads();
  /// `threads` as the pool uses it: <= 0 -> defaultThreads(), at most kMaxThreadsPerCore x defaultThreads()
  /// (`warning` set, when not null, to why it was capped).
  static int usableThreads(int threads, std::string* warning = nullptr);
  /// Threads per hardware thread a pool creates at most.
  static constexpr int kMaxThreadsPerCore = 4;

private:
  void workerLoop(int id);

  int Count;
  bool LowPriority = false;
  std::vector<std::thread> Workers;
  std::mutex Mutex;
  std::condition_variable Wake;
  std::condition_variable Done;
  const std::function<void(int)>* Job = nullptr;
  uint64_t Generation = 0;
  int Pending = 0;
  bool Stop = false;
  std::exception_ptr Failure;
};

} // namespace nv
