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
  TraceCounters counters;
};

void addCounters(TraceCounters& total, const std::vector<WorkerCounters>& w)
{
  for (const WorkerCounters& x : w)
  {
    total.evaluated += x.counters.evaluated;
    total.plain += x.counters.plain;
    total.cancelled = total.cancelled || x.counters.cancelled;
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
    TraceCounters& c = counters[static_cast<size_t>(w)].counters;
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

namespace
{
/// Sample Streaming's wavefront loop (traceStreaming): the live rays, the batch buffers reused from wavefront to
/// wavefront, and the steps of one wavefront.
class StreamingWavefront
{
public:
  StreamingWavefront(ThreadPool& pool, const ray::Params& P, int spp, int K, const CpuInference& net, float* rgba,
    RenderControl* control, TraceCounters& counters, int64_t queryBudget)
    : Pool(pool)
    , RayParams(P)
    , Spp(spp)
    , StepsPerEmit(K)
    , Net(net)
    , Rgba(rgba)
    , Control(control)
    , Counters(counters)
    , Rays(int64_t(P.width) * P.height * spp)
    , QueriesPerSlot(K * ray::queriesPerStep(P))
    , MaxLive(std::max<int64_t>(1024, queryBudget / QueriesPerSlot))
  {
    Live.reserve(static_cast<size_t>(std::min(Rays, MaxLive)));
  }

  void run()
  {
    admit();
    while (!Live.empty())
    {
      if (cancelRequested(Control))
      {
        Counters.cancelled = true;
        return;
      }
      const int64_t total = emitSteps();
      if (!inferBatch(total))
        return;
      ++Counters.wavefronts;
      consumeValues();
      retireFinished();
      admit();
    }
  }

private:
  struct Slot
  {
    ray::Ray state;
    int64_t iterations; ///< emit steps so far (a runaway ray throws)
  };

  /// A finished ray's result added to its pixel.
  NV_HD_INLINE void retire(const Slot& s)
  {
    addFinished(Control, 1);
    Counters.plain += s.state.plain;
    float o[4];
    ray::result(s.state, o);
    float* dst = Rgba + 4 * static_cast<size_t>(s.state.pixel);
    for (int k = 0; k < 4; ++k)
      dst[k] += o[k];
  }

  /// Admit new rays (initialised in parallel) until the live list is full; rays that miss the volume retire at once.
  void admit()
  {
    const ray::Params& P = RayParams;
    const int width = P.width;
    while (Next < Rays && static_cast<int64_t>(Live.size()) < MaxLive)
    {
      const int64_t m = std::min(Rays - Next, MaxLive - static_cast<int64_t>(Live.size()));
      Fresh.resize(static_cast<size_t>(m));
      Pool.parallelFor(m, [&](int64_t b, int64_t e, int) {
        for (int64_t i = b; i < e; ++i)
        {
          const int64_t g = Next + i, pixel = g / Spp; // ray g: pixel g / spp, path g % spp
          Slot& s = Fresh[static_cast<size_t>(i)];
          s.iterations = 0;
          ray::initRay(P, static_cast<int>(pixel % width), static_cast<int>(pixel / width), s.state,
            static_cast<uint32_t>(g % Spp));
        }
      });
      for (const Slot& s : Fresh)
      {
        if (s.state.phase == ray::Done)
          retire(s);
        else
          Live.push_back(s);
      }
      Next += m;
    }
  }

  /// 1. Every live ray emits up to K steps into its slot; Offset gets the slots' places in the batch. Returns the
  /// batch's query count.
  int64_t emitSteps()
  {
    const ray::Params& P = RayParams;
    const int K = StepsPerEmit;
    const int64_t nLive = static_cast<int64_t>(Live.size());
    const int cap = QueriesPerSlot;
    SlotQueries.resize(static_cast<size_t>(nLive) * cap * 3);
    Count.resize(static_cast<size_t>(nLive));
    Offset.resize(static_cast<size_t>(nLive) + 1);
    Pool.parallelFor(nLive, [&](int64_t b, int64_t e, int) {
      for (int64_t i = b; i < e; ++i)
      {
        Slot& s = Live[static_cast<size_t>(i)];
        if (++s.iterations > kMaxRayIterations)
          runaway();
        ray::V3* q = reinterpret_cast<ray::V3*>(SlotQueries.data() + static_cast<size_t>(i) * cap * 3);
        Count[static_cast<size_t>(i)] = ray::emit(P, s.state, K, q);
      }
    });
    Offset[0] = 0;
    for (int64_t i = 0; i < nLive; ++i)
      Offset[static_cast<size_t>(i) + 1] = Offset[static_cast<size_t>(i)] + Count[static_cast<size_t>(i)];
    return Offset[static_cast<size_t>(nLive)];
  }

  /// 2. One batch: the slots' queries packed, inferred together on the pool. False when cancelled.
  bool inferBatch(int64_t total)
  {
    const int64_t nLive = static_cast<int64_t>(Live.size());
    const int cap = QueriesPerSlot;
    Batch.resize(static_cast<size_t>(total) * 3);
    Values.resize(static_cast<size_t>(total));
    Pool.parallelFor(nLive, [&](int64_t b, int64_t e, int) {
      for (int64_t i = b; i < e; ++i)
        std::copy_n(SlotQueries.data() + static_cast<size_t>(i) * cap * 3, 3 * Count[static_cast<size_t>(i)],
          Batch.data() + 3 * Offset[static_cast<size_t>(i)]);
    });
    // Sliced so that a cancelled render stops within one slice (each query is evaluated on its own: the same values).
    for (int64_t first = 0; first < total; first += kInferenceSlice)
    {
      if (cancelRequested(Control))
      {
        Counters.cancelled = true;
        return false;
      }
      const int64_t slice = std::min(kInferenceSlice, total - first);
      Net.inferPoints(Pool, Batch.data() + 3 * first, slice, Values.data() + first);
      Counters.evaluated += slice;
    }
    return true;
  }

  /// 3. Every ray consumes its values in order.
  void consumeValues()
  {
    const ray::Params& P = RayParams;
    const int K = StepsPerEmit;
    const int64_t nLive = static_cast<int64_t>(Live.size());
    Pool.parallelFor(nLive, [&](int64_t b, int64_t e, int) {
      for (int64_t i = b; i < e; ++i)
      {
        Slot& s = Live[static_cast<size_t>(i)];
        float* v = Values.data() + Offset[static_cast<size_t>(i)];
        ray::maskOutsideDomain(P, reinterpret_cast<const ray::V3*>(Batch.data() + 3 * Offset[static_cast<size_t>(i)]),
          v, static_cast<int>(Count[static_cast<size_t>(i)]));
        ray::consume(P, s.state, K, v, Count[static_cast<size_t>(i)]);
      }
    });
  }

  /// 4. Retire finished rays (in list order: deterministic) and compact the live list.
  void retireFinished()
  {
    size_t keep = 0;
    for (size_t i = 0; i < Live.size(); ++i)
    {
      if (Live[i].state.phase == ray::Done)
        retire(Live[i]);
      else
        Live[keep++] = Live[i];
    }
    Live.resize(keep);
  }

  ThreadPool& Pool;
  const ray::Params& RayParams;
  const int Spp;          ///< paths per pixel
  const int StepsPerEmit; ///< K: steps a ray emits per wavefront
  const CpuInference& Net;
  float* const Rgba;
  RenderControl* const Control;
  TraceCounters& Counters;
  const int64_t Rays;           ///< width * height * spp
  const int QueriesPerSlot;     ///< K steps' queries: a live ray's slot in SlotQueries
  const int64_t MaxLive;        ///< live rays at most (queryBudget / QueriesPerSlot, at least 1024)
  std::vector<Slot> Live;       ///< rays in flight, in admission order
  std::vector<Slot> Fresh;      ///< rays being admitted
  std::vector<float> SlotQueries; ///< the live rays' emitted queries, QueriesPerSlot xyz triples per ray
  std::vector<float> Batch;     ///< the queries packed (xyz)
  std::vector<float> Values;    ///< their values
  std::vector<int> Count;       ///< queries each live ray emitted
  std::vector<int64_t> Offset;  ///< where each live ray's queries start in Batch (and Values)
  int64_t Next = 0;             ///< the next ray to admit
};
} // namespace

void traceStreaming(ThreadPool& pool, const ray::Params& P, int spp, int K, const CpuInference& net, float* rgba,
  RenderControl* control, TraceCounters& counters, int64_t queryBudget)
{
  StreamingWavefront wavefront(pool, P, spp, K, net, rgba, control, counters, queryBudget);
  wavefront.run();
}

} // namespace nv
