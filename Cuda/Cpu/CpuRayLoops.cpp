#include "CpuRayLoops.h"

#include "Core/Error.h"
#include "CpuInference.h"
#include "CpuGridSampler.h"
#include "CpuHalfNetwork.h"
#include "ThreadPool.h"

#include <algorithm>
#include <vector>

namespace nv
{

namespace
{
static_assert(sizeof(ray::V3) == 3 * sizeof(float), "queries are passed to the evaluators as xyz triples");

struct alignas(64) WorkerCounters
{
  TraceCounters c;
};

void addCounters(TraceCounters& total, const std::vector<WorkerCounters>& w)
{
  for (const WorkerCounters& x : w)
  {
    total.evaluated += x.c.evaluated;
    total.plain += x.c.plain;
    total.cancelled = total.cancelled || x.c.cancelled;
  }
}

bool cancelRequested(const RenderControl* control)
{
  return control && control->cancel.load(std::memory_order_relaxed);
}

void addFinished(RenderControl* control, int64_t rays)
{
  if (control && rays > 0)
    control->raysFinished.fetch_add(rays, std::memory_order_relaxed);
}

[[noreturn]] void runaway()
{
  NV_THROW("a ray did not finish within " + std::to_string(kMaxRayIterations) +
    " steps (sample distance or opacity unit distance far too small for the volume)");
}

/// Per-ray paths: tiles of 8 x 8 pixels handed out dynamically; each pixel's paths run the machine with K = 1.
template <class Field>
void tracePerRay(ThreadPool& pool, const ray::Params& P, int spp, const Field& field, float* rgba,
  RenderControl* control, TraceCounters& total)
{
  const int width = P.width, height = P.height;
  const int tilesX = (width + 7) / 8, tilesY = (height + 7) / 8;
  std::vector<WorkerCounters> counters(static_cast<size_t>(pool.size()));
  pool.parallelChunks(int64_t(tilesX) * tilesY, 1, [&](int64_t b, int64_t e, int w) {
    TraceCounters& c = counters[static_cast<size_t>(w)].c;
    ray::V3 q[ray::kMaxQueriesPerStep];
    float v[ray::kMaxQueriesPerStep];
    for (int64_t tile = b; tile < e && !c.cancelled; ++tile)
    {
      const int x0 = static_cast<int>(tile % tilesX) * 8, y0 = static_cast<int>(tile / tilesX) * 8;
      int64_t finished = 0;
      for (int py = y0; py < std::min(height, y0 + 8) && !c.cancelled; ++py)
        for (int px = x0; px < std::min(width, x0 + 8); ++px)
        {
          if (cancelRequested(control))
          {
            c.cancelled = true;
            break;
          }
          finished += spp;
          float sum[4] = { 0.0f, 0.0f, 0.0f, 0.0f };
          for (int sample = 0; sample < spp; ++sample)
          {
            ray::Ray r;
            ray::initRay(P, px, py, r, static_cast<uint32_t>(sample));
            for (int64_t it = 0; r.phase != ray::Done; ++it)
            {
              if (it >= kMaxRayIterations)
                runaway();
              const int n = ray::emit(P, r, 1, q);
              field(q, n, v);
              ray::maskOutsideDomain(P, q, v, n);
              c.evaluated += n;
              ray::consume(P, r, 1, v, n);
            }
            c.plain += r.plain;
            float o[4];
            ray::result(r, o);
            for (int k = 0; k < 4; ++k)
              sum[k] += o[k];
          }
          float* dst = rgba + 4 * (static_cast<size_t>(py) * width + px);
          for (int k = 0; k < 4; ++k)
            dst[k] += sum[k];
        }
      addFinished(control, finished);
    }
  });
  addCounters(total, counters);
}
} // namespace

void traceDecode(ThreadPool& pool, const ray::Params& P, int spp, const CpuGridSampler& grid, float* rgba,
  RenderControl* control, TraceCounters& counters)
{
  tracePerRay(
    pool, P, spp,
    [&grid](const ray::V3* q, int n, float* v) {
      for (int i = 0; i < n; ++i)
        v[i] = grid(&q[i].x);
    },
    rgba, control, counters);
}

void traceInShader(ThreadPool& pool, const ray::Params& P, int spp, const CpuHalfNetwork& net, float* rgba,
  RenderControl* control, TraceCounters& counters)
{
  tracePerRay(
    pool, P, spp, [&net](const ray::V3* q, int n, float* v) { net.evaluate(&q[0].x, n, v); }, rgba, control,
    counters);
}

void traceStreaming(ThreadPool& pool, const ray::Params& P, int spp, int K, const CpuInference& net, float* rgba,
  RenderControl* control, TraceCounters& counters, int64_t queryBudget)
{
  const int width = P.width;
  const int64_t rays = int64_t(P.width) * P.height * spp; // ray g: pixel g / spp, path g % spp
  const int cap = K * ray::queriesPerStep(P);
  const int64_t maxLive = std::max<int64_t>(1024, queryBudget / cap);

  struct Slot
  {
    ray::Ray r;
    int64_t iterations;
  };
  std::vector<Slot> live, fresh;
  live.reserve(static_cast<size_t>(std::min(rays, maxLive)));
  std::vector<float> slotQueries, batch, values;
  std::vector<int> count;
  std::vector<int64_t> offset;
  int64_t next = 0;

  auto retire = [&](const Slot& s) {
    addFinished(control, 1);
    counters.plain += s.r.plain;
    float o[4];
    ray::result(s.r, o);
    float* dst = rgba + 4 * static_cast<size_t>(s.r.pixel);
    for (int k = 0; k < 4; ++k)
      dst[k] += o[k];
  };
  // Admit new rays (initialised in parallel) until the live list is full; rays that miss the volume retire at once.
  auto admit = [&] {
    while (next < rays && static_cast<int64_t>(live.size()) < maxLive)
    {
      const int64_t m = std::min(rays - next, maxLive - static_cast<int64_t>(live.size()));
      fresh.resize(static_cast<size_t>(m));
      pool.parallelFor(m, [&](int64_t b, int64_t e, int) {
        for (int64_t i = b; i < e; ++i)
        {
          const int64_t g = next + i, pixel = g / spp;
          Slot& s = fresh[static_cast<size_t>(i)];
          s.iterations = 0;
          ray::initRay(P, static_cast<int>(pixel % width), static_cast<int>(pixel / width), s.r,
            static_cast<uint32_t>(g % spp));
        }
      });
      for (const Slot& s : fresh)
      {
        if (s.r.phase == ray::Done)
          retire(s);
        else
          live.push_back(s);
      }
      next += m;
    }
  };

  admit();
  while (!live.empty())
  {
    if (cancelRequested(control))
    {
      counters.cancelled = true;
      return;
    }
    const int64_t nLive = static_cast<int64_t>(live.size());
    slotQueries.resize(static_cast<size_t>(nLive) * cap * 3);
    count.resize(static_cast<size_t>(nLive));
    offset.resize(static_cast<size_t>(nLive) + 1);
    // 1. every live ray emits up to K steps into its slot
    pool.parallelFor(nLive, [&](int64_t b, int64_t e, int) {
      for (int64_t i = b; i < e; ++i)
      {
        Slot& s = live[static_cast<size_t>(i)];
        if (++s.iterations > kMaxRayIterations)
          runaway();
        ray::V3* q = reinterpret_cast<ray::V3*>(slotQueries.data() + static_cast<size_t>(i) * cap * 3);
        count[static_cast<size_t>(i)] = ray::emit(P, s.r, K, q);
      }
    });
    offset[0] = 0;
    for (int64_t i = 0; i < nLive; ++i)
      offset[static_cast<size_t>(i) + 1] = offset[static_cast<size_t>(i)] + count[static_cast<size_t>(i)];
    const int64_t total = offset[static_cast<size_t>(nLive)];
    // 2. one batch: the slots' queries packed, inferred together on the pool
    batch.resize(static_cast<size_t>(total) * 3);
    values.resize(static_cast<size_t>(total));
    pool.parallelFor(nLive, [&](int64_t b, int64_t e, int) {
      for (int64_t i = b; i < e; ++i)
        std::copy_n(slotQueries.data() + static_cast<size_t>(i) * cap * 3, 3 * count[static_cast<size_t>(i)],
          batch.data() + 3 * offset[static_cast<size_t>(i)]);
    });
    // Sliced so that a cancelled render stops within one slice (each query is evaluated on its own: the same values).
    for (int64_t first = 0; first < total; first += kInferenceSlice)
    {
      if (cancelRequested(control))
      {
        counters.cancelled = true;
        return;
      }
      const int64_t slice = std::min(kInferenceSlice, total - first);
      net.inferPoints(pool, batch.data() + 3 * first, slice, values.data() + first);
      counters.evaluated += slice;
    }
    ++counters.wavefronts;
    // 3. every ray consumes its values in order
    pool.parallelFor(nLive, [&](int64_t b, int64_t e, int) {
      for (int64_t i = b; i < e; ++i)
      {
        Slot& s = live[static_cast<size_t>(i)];
        float* v = values.data() + offset[static_cast<size_t>(i)];
        ray::maskOutsideDomain(P, reinterpret_cast<const ray::V3*>(batch.data() + 3 * offset[static_cast<size_t>(i)]),
          v, static_cast<int>(count[static_cast<size_t>(i)]));
        ray::consume(P, s.r, K, v, count[static_cast<size_t>(i)]);
      }
    });
    // 4. retire finished rays (in list order: deterministic), compact, admit waiting rays
    size_t keep = 0;
    for (size_t i = 0; i < live.size(); ++i)
    {
      if (live[i].r.phase == ray::Done)
        retire(live[i]);
      else
        live[keep++] = live[i];
    }
    live.resize(keep);
    admit();
  }
}

} // namespace nv
