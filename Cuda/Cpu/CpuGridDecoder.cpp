#include "CpuGridDecoder.h"

#include "Core/ThreadPriority.h"

#include "Core/Error.h"
#include "Core/Model.h"
#include "CpuInference.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <new>
#include <string>
#include <system_error>

namespace nv
{

namespace
{
/// Largest grid the CPU renderer decodes (8 GiB of floats).
constexpr int64_t kMaxDecodeSamples = int64_t(1) << 31;

/// The error-bounded mode: a grid of the source's own dims gets the model's corrections (slices [z0, z1), normalised).
void correctDecoded(const Model& model, const int64_t dims[3], int64_t z0, int64_t z1, float* values)
{
  const int64_t* source = model.source.dims;
  if (!model.corrections.enabled() || dims[0] != source[0] || dims[1] != source[1] || dims[2] != source[2])
    return;
  const int64_t slice = dims[0] * dims[1];
  applyCorrectionsNormalised(
    model.corrections, z0 * slice, (z1 - z0) * slice, model.source.valueMin, model.source.valueMax, values);
}
} // namespace

struct CpuGridDecoder::Job
{
  explicit Job(const Model& m)
    : model(m)
  {
  }
  Model model; ///< a copy: the caller's model may change while the job runs
  uint64_t version = 0;
  int64_t dims[3] = { 0, 0, 0 };
  std::atomic<bool> cancel{ false };
  std::atomic<bool> done{ false };     ///< the job's thread has ended
  std::shared_ptr<DecodedGrid> result; ///< null when cancelled or failed
  std::string error;
  std::thread thread;
  // The grid is decoded in blocks of z slices that any thread may claim: the job's thread, and a caller that waits
  // for the full grid (finish()) with the session's pool.
  std::shared_ptr<DecodedGrid> grid;   ///< allocated by the job's thread before `ready`
  std::atomic<bool> ready{ false };
  int64_t block = 1;                   ///< z slices per block
  int64_t blocks = 0;
  std::atomic<int64_t> next{ 0 };      ///< the next unclaimed block
  std::atomic<int64_t> finished{ 0 };  ///< blocks decoded

  /// Claims and decodes blocks on `pool` until none is left (or the job is cancelled).
  void work(ThreadPool& pool, const CpuInference& net)
  {
    const int64_t slice = dims[0] * dims[1];
    for (;;)
    {
      if (cancel.load())
        return;
      const int64_t b = next.fetch_add(1);
      if (b >= blocks)
        return;
      const int64_t z0 = b * block, z1 = std::min(dims[2], z0 + block);
      net.decodeGrid(pool, dims[0], dims[1], dims[2], z0, z1, grid->values.data() + z0 * slice);
      correctDecoded(model, dims, z0, z1, grid->values.data() + z0 * slice);
      finished.fetch_add(1);
    }
  }

  /// The job's thread: allocates the grid, decodes blocks on `pool` (alongside a caller that waits), then publishes
  /// the result (unless cancelled) or the error, and sets `done`.
  void run(ThreadPool& pool, bool lowPriority)
  {
    if (lowPriority)
      lowerCurrentThreadPriority(); // the pool's worker 0
    try
    {
      auto g = std::make_shared<DecodedGrid>();
      g->values.resize(static_cast<size_t>(dims[0] * dims[1] * dims[2]));
      grid = g;
      ready = true;
      const CpuInference net(model);
      work(pool, net);
      if (!cancel.load())
      {
        g->id = newGridId();
        g->version = version;
        g->decodedAt = std::chrono::steady_clock::now();
        for (int a = 0; a < 3; ++a)
          g->dims[a] = dims[a];
        result = g; // complete once every block is decoded (a helping caller may still be on its last ones)
      }
    }
    catch (const std::bad_alloc&)
    {
      error = "out of memory for a decode grid of " + std::to_string(dims[0] * dims[1] * dims[2]) + " samples";
    }
    catch (const std::exception& e)
    {
      error = e.what();
    }
    done = true;
  }
};

CpuGridDecoder::CpuGridDecoder(ThreadPool& pool, int64_t progressiveSamples)
  : Pool(pool)
  , ProgressiveSamples(std::max<int64_t>(1, progressiveSamples))
  , Background(std::max(1, pool.size() - 1), pool.lowPriority())
{
}

CpuGridDecoder::~CpuGridDecoder()
{
  cancelJob();
}

uint64_t CpuGridDecoder::newGridId()
{
  static std::atomic<uint64_t> next{ 1 };
  return next.fetch_add(1);
}

bool CpuGridDecoder::matches(const DecodedGrid* g, uint64_t version, const int64_t dims[3])
{
  return g && g->version == version && g->dims[0] == dims[0] && g->dims[1] == dims[1] && g->dims[2] == dims[2];
}

void CpuGridDecoder::cancelJob()
{
  if (!Running)
    return;
  Running->cancel = true;
  if (Running->thread.joinable())
    Running->thread.join();
  Running.reset();
  Pending = false;
}

void CpuGridDecoder::coarseDims(const int64_t dims[3], int64_t out[3]) const
{
  for (int a = 0; a < 3; ++a)
    out[a] = dims[a] <= 1 ? 1 : std::max<int64_t>(2, dims[a] / 4);
  while (out[0] * out[1] * out[2] > std::max<int64_t>(8, ProgressiveSamples / 8) &&
    (out[0] > 2 || out[1] > 2 || out[2] > 2))
    for (int a = 0; a < 3; ++a)
      out[a] = out[a] <= 1 ? 1 : std::max<int64_t>(2, out[a] / 2);
}

std::shared_ptr<DecodedGrid> CpuGridDecoder::decode(ThreadPool& pool, const Model& model, uint64_t version,
  const int64_t dims[3], const std::atomic<bool>* cancel)
{
  for (int a = 0; a < 3; ++a)
    NV_CHECK(dims[a] >= 1, "decode grid dimensions must be >= 1");
  const int64_t samples = dims[0] * dims[1] * dims[2];
  if (samples > kMaxDecodeSamples)
    NV_THROW("decode grid of " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
      std::to_string(dims[2]) + " samples is larger than the CPU renderer's limit of 2^31 samples");
  auto g = std::make_shared<DecodedGrid>();
  try
  {
    g->values.resize(static_cast<size_t>(samples));
  }
  catch (const std::bad_alloc&)
  {
    NV_THROW("out of memory for a decode grid of " + std::to_string(samples) + " samples");
  }
  const CpuInference net(model);
  // Blocks of slices of about 2^18 samples: a cancelled background decode stops within one block.
  const int64_t slice = dims[0] * dims[1];
  const int64_t block = cancel ? std::max<int64_t>(1, (int64_t(1) << 18) / slice) : dims[2];
  for (int64_t z0 = 0; z0 < dims[2]; z0 += block)
  {
    const int64_t z1 = std::min(dims[2], z0 + block);
    if (cancel && cancel->load())
      return nullptr;
    net.decodeGrid(pool, dims[0], dims[1], dims[2], z0, z1, g->values.data() + z0 * slice);
    correctDecoded(model, dims, z0, z1, g->values.data() + z0 * slice);
  }
  g->id = newGridId();
  g->version = version;
  g->decodedAt = std::chrono::steady_clock::now();
  for (int a = 0; a < 3; ++a)
    g->dims[a] = dims[a];
  return g;
}

std::shared_ptr<const DecodedGrid> CpuGridDecoder::decodeNow(const Model& model, uint64_t version,
  const int64_t dims[3], const std::atomic<bool>* cancel)
{
  if (matches(Full.get(), version, dims))
    return Full;
  return decode(Pool, model, version, dims, cancel);
}

void CpuGridDecoder::finishRunning()
{
  Job& j = *Running;
  // The job's thread allocates the grid first (or fails).
  while (!j.ready.load() && !j.done.load())
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  if (j.ready.load())
  {
    try
    {
      const CpuInference net(j.model);
      j.work(Pool, net);
    }
    catch (...)
    {
      cancelJob(); // a block this thread claimed will never be decoded
      throw;
    }
  }
  j.thread.join(); // it ends with the block it is decoding
  j.done = true;
  if (j.result && j.finished.load() != j.blocks)
    j.result.reset();
}

CpuGridDecoder::Result CpuGridDecoder::acquire(const Model& model, uint64_t version, const int64_t dims[3], bool wait)
{
  Result r;
  if (matches(Full.get(), version, dims))
  {
    r.grid = Full;
    return r;
  }
  if (Running && Running->version == version && Running->dims[0] == dims[0] && Running->dims[1] == dims[1] &&
    Running->dims[2] == dims[2])
    return takeRunning(wait);
  cancelJob(); // a job for another version or resolution: its result would be stale
  r.decoded = true;
  if (wait || dims[0] * dims[1] * dims[2] <= ProgressiveSamples)
  {
    Full = decode(Pool, model, version, dims, nullptr);
    r.grid = Full;
    return r;
  }
  return startBackgroundDecode(model, version, dims);
}

CpuGridDecoder::Result CpuGridDecoder::takeRunning(bool wait)
{
  Result r;
  if (wait && !Running->done.load())
    finishRunning(); // the caller waits: its pool decodes the blocks left, alongside the job's thread
  if (!Running->done.load())
  {
    r.grid = Coarse;
    r.pending = true;
    return r;
  }
  if (Running->thread.joinable())
    Running->thread.join();
  std::unique_ptr<Job> job = std::move(Running);
  Pending = false;
  if (!job->result)
    NV_THROW("background decode failed: " + (job->error.empty() ? std::string("cancelled") : job->error));
  Full = job->result;
  r.grid = Full;
  r.decoded = true; // the refined grid is new to the caller
  return r;
}

CpuGridDecoder::Result CpuGridDecoder::startBackgroundDecode(const Model& model, uint64_t version,
  const int64_t dims[3])
{
  Result r;
  r.decoded = true;
  int64_t cd[3];
  coarseDims(dims, cd);
  if (!matches(Coarse.get(), version, cd))
    Coarse = decode(Pool, model, version, cd, nullptr);
  // Check the full grid's size before starting (the job would only fail later).
  const int64_t samples = dims[0] * dims[1] * dims[2];
  NV_CHECK(samples <= kMaxDecodeSamples, "decode grid larger than the CPU renderer's limit of 2^31 samples");
  auto job = std::make_unique<Job>(model);
  job->version = version;
  for (int a = 0; a < 3; ++a)
    job->dims[a] = dims[a];
  Job* j = job.get();
  ThreadPool* pool = &Background;
  const bool lowPriority = Background.lowPriority();
  Pending = true;
  // Blocks of slices of about 2^18 samples: a cancelled background decode stops within one block.
  job->block = std::max<int64_t>(1, (int64_t(1) << 18) / (dims[0] * dims[1]));
  job->blocks = (dims[2] + job->block - 1) / job->block;
  try
  {
    job->thread = std::thread([j, pool, lowPriority] { j->run(*pool, lowPriority); });
  }
  catch (const std::system_error&)
  {
    // No thread to be had (a process limit): the full grid now, on the session's pool, instead of in the background.
    Pending = false;
    Full = decode(Pool, model, version, dims, nullptr);
    r.grid = Full;
    r.pending = false;
    return r;
  }
  Running = std::move(job);
  r.grid = Coarse;
  r.pending = true;
  return r;
}

} // namespace nv
