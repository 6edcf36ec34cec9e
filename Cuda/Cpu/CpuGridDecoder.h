// NeuralVolume engine: decoded grids of a network for the CPU renderer, cached per (network version, dims), and
// decoded progressively when large: a coarse grid now, the full grid on a background thread.
//
// The background decode works on its own copy of the model (the caller's model may change while it runs), on a
// pool of its own (the session's pool is busy rendering meanwhile; one core is left to interaction). A job is
// cancelled when a different grid is asked for and when the decoder is destroyed; a finished job's grid is used only
// if it still matches the request (stale results are dropped).
#pragma once

#include "ThreadPool.h"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

namespace nv
{

class Model;

/// Normalised field values on a grid over [0,1]^3 (sample i at i/(n-1)), x fastest.
struct DecodedGrid
{
  uint64_t id = 0;      ///< unique per contents (caches downstream key on it)
  uint64_t version = 0; ///< network version it was decoded from
  std::chrono::steady_clock::time_point decodedAt; ///< when (RenderRequest::liveRefreshMilliseconds ages it)
  int64_t dims[3] = { 0, 0, 0 };
  bool hasNaN = false;
  std::vector<float> values;
};

class CpuGridDecoder
{
public:
  /// Grids of more than `progressiveSamples` samples are decoded progressively.
  CpuGridDecoder(ThreadPool& pool, int64_t progressiveSamples);
  ~CpuGridDecoder();
  CpuGridDecoder(const CpuGridDecoder&) = delete;
  CpuGridDecoder& operator=(const CpuGridDecoder&) = delete;

  struct Result
  {
    std::shared_ptr<const DecodedGrid> grid;
    bool pending = false;   ///< a coarser grid: the full one is being decoded in the background
    bool decoded = false;   ///< this call decoded something (not only a cache lookup)
  };

  /// The grid to render `dims` of `model` (version `version`) with: the full grid when cached or small enough to
  /// decode now, else a coarse one while the full grid decodes in the background. `wait`: the full grid in any case
  /// (decoded now on the session's pool; a background decode of it already running is finished by both: the
  /// blocks left are shared between its thread and the session's pool).
  Result acquire(const Model& model, uint64_t version, const int64_t dims[3], bool wait = false);

  /// The full grid, decoded now on the session's pool when not cached (never progressive). `cancel` (may be null)
  /// set: stops within a block of 2^18 samples and returns null.
  std::shared_ptr<const DecodedGrid> decodeNow(const Model& model, uint64_t version, const int64_t dims[3],
    const std::atomic<bool>* cancel = nullptr);

  /// The last full grid when it is `dims` of version `version` (else null): no decode.
  std::shared_ptr<const DecodedGrid> cached(uint64_t version, const int64_t dims[3]) const
  {
    return matches(Full.get(), version, dims) ? Full : nullptr;
  }

  /// The last full grid when it has `dims`, of any network version (else null): no decode.
  std::shared_ptr<const DecodedGrid> lastFull(const int64_t dims[3]) const
  {
    const DecodedGrid* g = Full.get();
    return g && g->dims[0] == dims[0] && g->dims[1] == dims[1] && g->dims[2] == dims[2] ? Full : nullptr;
  }

  /// True from the start of a background decode until its grid has been handed out by acquire() (or dropped).
  bool workPending() const { return Pending.load(); }

  /// Dims of the coarse grid used while `dims` decodes: dims/4 per axis (at least 2, or 1 where dims is 1), halved
  /// further until it has at most progressiveSamples / 8 samples.
  void coarseDims(const int64_t dims[3], int64_t out[3]) const;

  static uint64_t newGridId();

private:
  struct Job;
  void cancelJob();
  /// Decodes the running job's remaining blocks on Pool, then joins its thread.
  void finishRunning();
  /// acquire() while the running job decodes the grid asked for: its grid once done (`wait`: finished first),
  /// else the coarse one (pending).
  Result takeRunning(bool wait);
  /// acquire() of a grid too large to decode now: the coarse grid (decoded now unless cached) while a background
  /// job decodes the full one (or the full one now when no thread can be started).
  Result startBackgroundDecode(const Model& model, uint64_t version, const int64_t dims[3]);
  static std::shared_ptr<DecodedGrid> decode(ThreadPool& pool, const Model& model, uint64_t version,
    const int64_t dims[3], const std::atomic<bool>* cancel);
  static bool matches(const DecodedGrid* g, uint64_t version, const int64_t dims[3]);

  ThreadPool& Pool;
  int64_t ProgressiveSamples;
  std::shared_ptr<const DecodedGrid> Full;   ///< the last full grid
  std::shared_ptr<const DecodedGrid> Coarse; ///< the last coarse grid
  ThreadPool Background;                     ///< the background decode's pool (created once)
  std::unique_ptr<Job> Running;
  std::atomic<bool> Pending{ false };
};

} // namespace nv
