#include "CpuRenderer.h"

#include "Core/Error.h"
#include "Core/RenderSetup.h"
#include "Core/ValueRange.h"
#include "CpuGridSampler.h"
#include "CpuHalfNetwork.h"
#include "CpuInference.h"
#include "CpuRayLoops.h"
#include "ThreadPool.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <new>
#include <string>

namespace nv
{

namespace
{
using Clock = std::chrono::steady_clock;

double millis(Clock::time_point a, Clock::time_point b)
{
  return std::chrono::duration<double, std::milli>(b - a).count();
}

uint64_t combine(uint64_t a, uint64_t b)
{
  return mix64(a ^ mix64(b + 0x9E3779B97F4A7C15ull));
}
} // namespace

CpuRenderer::CpuRenderer(ThreadPool& pool, const CpuRendererOptions& options)
  : Pool(pool)
  , Options(options)
  , Decoder(pool, options.progressiveSamples)
{
  NV_CHECK(options.latticeMax >= 2, "the macrocell lattice needs at least 2 samples per axis");
  NV_CHECK(options.probesPerCell >= 0 && options.maxProbes >= 1, "macrocell probes must be >= 0");
}

CpuRenderer::~CpuRenderer() = default; // the decoder cancels and joins its background job

bool CpuRenderer::workPending() const
{
  return DecodeShown.load() && Decoder.workPending();
}

std::shared_ptr<const DecodedGrid> CpuRenderer::referenceGrid(const Model& model, const VolumeView& v)
{
  const double lo = model.source.valueMin, hi = model.source.valueMax;
  if (Reference && ReferenceData == v.data && ReferenceType == static_cast<int>(v.type) &&
    Reference->dims[0] == v.dims[0] && Reference->dims[1] == v.dims[1] && Reference->dims[2] == v.dims[2] &&
    ReferenceRange[0] == lo && ReferenceRange[1] == hi)
    return Reference;
  for (int a = 0; a < 3; ++a)
    NV_CHECK(v.dims[a] >= 1, "the reference grid's dimensions must be >= 1");
  auto g = std::make_shared<DecodedGrid>();
  const int64_t n = v.count();
  g->values.resize(static_cast<size_t>(n));
  const ValueRange range(lo, hi);
  std::vector<uint8_t> nan(static_cast<size_t>(Pool.size()), 0);
  Pool.parallelFor(n, [&](int64_t b, int64_t e, int w) {
    for (int64_t i = b; i < e; ++i)
    {
      const double x = v.at(i);
      const bool ok = std::isfinite(x);
      g->values[static_cast<size_t>(i)] = ok ? static_cast<float>(range.normalize(x)) : NAN;
      nan[static_cast<size_t>(w)] |= ok ? 0 : 1;
    }
  });
  g->hasNaN = std::find(nan.begin(), nan.end(), 1) != nan.end();
  g->id = CpuGridDecoder::newGridId();
  for (int a = 0; a < 3; ++a)
    g->dims[a] = v.dims[a];
  Reference = g;
  ReferenceData = v.data;
  ReferenceType = static_cast<int>(v.type);
  ReferenceRange[0] = lo;
  ReferenceRange[1] = hi;
  return Reference;
}

std::shared_ptr<const DecodedGrid> CpuRenderer::networkLattice(const Model& model, uint64_t version,
  const RenderControl* control)
{
  int64_t dims[3];
  for (int a = 0; a < 3; ++a)
    dims[a] = std::max<int64_t>(1, std::min<int64_t>(model.source.dims[a], Options.latticeMax));
  if (Lattice && Lattice->version == version && Lattice->dims[0] == dims[0] && Lattice->dims[1] == dims[1] &&
    Lattice->dims[2] == dims[2])
    return Lattice;
  // (A new network version decodes 2^21 samples: cancellable, as a publish while training starts it again.)
  std::shared_ptr<const DecodedGrid> lattice =
    Decoder.decodeNow(model, version, dims, control ? &control->cancel : nullptr);
  if (lattice)
    Lattice = lattice;
  return lattice;
}

void CpuRenderer::render(const Model& model, uint64_t version, const RenderRequest& q, RenderResult& out)
{
  try
  {
    renderImpl(model, version, q, out);
  }
  catch (const std::bad_alloc&)
  {
    Accum.clear();
    AccumFrames = 0;
    NV_THROW("out of memory rendering a " + std::to_string(q.width) + " x " + std::to_string(q.height) + " image (" +
      renderPathName(q.path) + ", " + shadingModeName(q.shading) + ")");
  }
}

void CpuRenderer::renderImpl(const Model& model, uint64_t version, const RenderRequest& q, RenderResult& out)
{
  const Clock::time_point t0 = Clock::now();
  NV_CHECK(model.paramCount() > 0 && model.paramCount() == model.encodingParamCount() + model.mlpParamCount(),
    "the model has no parameters");
  if (q.grid && q.path != RenderPath::Decode)
    NV_THROW(std::string("invalid render request: a reference grid is rendered by the Decode path only (path is ") +
      renderPathName(q.path) + ")");
  auto cancelled = [&] {
    out.rgba.clear();
    out.deviceRgba = nullptr;
    out.stats = RenderStats();
    out.stats.path = q.path;
    out.stats.cancelled = true;
  };
  if (q.control && q.control->cancel.load())
  {
    cancelled();
    return;
  }
  RenderSetup setup = makeRenderSetup(q, model.source);
  DecodeShown = q.path == RenderPath::Decode && !q.grid;
  ray::Params& P = setup.params;
  RenderStats st;
  st.path = q.path;
  st.device = Device::Cpu;

  // 1. The field and its macrocells: the grid itself for Decode (exact ranges), a lattice of the network otherwise
  // (ranges widened by network probes inside each cell).
  std::shared_ptr<const DecodedGrid> grid, lattice;
  if (q.path == RenderPath::Decode)
  {
    if (q.grid)
      grid = referenceGrid(model, *q.grid);
    else
    {
      const CpuGridDecoder::Result a = Decoder.acquire(model, version, setup.gridDims, q.waitForDecode);
      grid = a.grid;
      st.decodePending = a.pending;
    }
    lattice = grid;
    Cells.updateRanges(Pool, setup.cells, lattice->values.data(), lattice->dims, lattice->id);
  }
  else
  {
    lattice = networkLattice(model, version, q.control);
    if (!lattice)
    {
      cancelled();
      return;
    }
    const int64_t cells = int64_t(setup.cells.dims[0]) * setup.cells.dims[1] * setup.cells.dims[2];
    const CpuInference net(model);
    if (Options.probesPerCell > 0)
    {
      const int probes = static_cast<int>(std::max<int64_t>(4, std::min<int64_t>(Options.probesPerCell,
        Options.maxProbes / cells)));
      Cells.updateRanges(Pool, setup.cells, lattice->values.data(), lattice->dims, lattice->id, 0.0f, &net, probes);
    }
    else
      Cells.updateRanges(Pool, setup.cells, lattice->values.data(), lattice->dims, lattice->id, kNetworkRangeMargin);
  }
  if (P.occupancy)
    Cells.setEmptyCells(P.occupancy, P.background);
  Cells.updateMajorants(Pool, setup.table.data(), P.tfSize, P.tfScale, P.tfShift, setup.tableKey);
  P.tf = setup.table.data();
  P.majorant = Cells.majorants();
  P.maxMajorant = Cells.maxMajorant();
  P.depth = q.depth;
  const Clock::time_point t1 = Clock::now();
  st.decodeMilliseconds = millis(t0, t1);

  // 2. An identical deterministic request returns the previous image.
  const bool pathTrace = q.shading == ShadingMode::PathTrace || q.shading == ShadingMode::PathTraceNee;
  const uint64_t key = combine(combine(setup.key, version), lattice->id);
  const size_t values = static_cast<size_t>(q.width) * static_cast<size_t>(q.height) * 4;
  const bool deterministic = !pathTrace || !q.accumulate;
  if (deterministic && key == ImageKey && Image.size() == values)
  {
    out.rgba = Image;
    out.deviceRgba = nullptr;
    out.stats = ImageStats;
    out.stats.reused = true;
    out.stats.decodeMilliseconds = st.decodeMilliseconds;
    out.stats.renderMilliseconds = millis(t1, Clock::now());
    return;
  }

  // 3. Path tracing continues the accumulation while nothing changed; every path has its own frame index.
  int frame = 0;
  const int spp = pathTrace ? q.samplesPerPixel : 1;
  std::vector<float> local;
  float* target;
  if (pathTrace)
  {
    if (!(q.accumulate && key == AccumKey && Accum.size() == values && AccumFrames > 0))
    {
      Accum.assign(values, 0.0f);
      AccumFrames = 0;
      AccumKey = key;
    }
    frame = AccumFrames;
    target = Accum.data();
  }
  else
  {
    local.assign(values, 0.0f);
    target = local.data();
  }
  P.frame = static_cast<uint32_t>(frame) * static_cast<uint32_t>(spp); // path s of this render: P.frame + s

  // 4. Trace: the same machine, three ways of evaluating its queries.
  TraceCounters c;
  auto trace = [&] {
    switch (q.path)
    {
      case RenderPath::Decode:
      {
        const CpuGridSampler sampler(grid->values.data(), grid->dims, grid->hasNaN);
        traceDecode(Pool, P, spp, sampler, target, q.control, c);
        break;
      }
      case RenderPath::InShader:
      {
        HalfTable.update(model, version);
        const CpuHalfNetwork net(model, HalfTable.table());
        traceInShader(Pool, P, spp, net, target, q.control, c);
        break;
      }
      case RenderPath::SampleStreaming:
      {
        const CpuInference net(model);
        traceStreaming(Pool, P, spp, setup.streamingSamples, net, target, q.control, c);
        break;
      }
    }
  };
  try
  {
    trace();
  }
  catch (...)
  {
    // A partial frame would corrupt the accumulation: start over next time.
    Accum.clear();
    AccumFrames = 0;
    throw;
  }
  st.rays = static_cast<int64_t>(q.width) * q.height * spp;
  st.samplesEvaluated = c.evaluated;
  if (c.cancelled)
  {
    // Stopped by the caller: nothing is cached, a partial path-tracing frame is not averaged in.
    if (pathTrace)
    {
      Accum.clear();
      AccumFrames = 0;
    }
    st.cancelled = true;
    st.wavefronts = c.wavefronts;
    st.renderMilliseconds = millis(t1, Clock::now());
    out.rgba.clear();
    out.deviceRgba = nullptr;
    out.stats = st;
    return;
  }
  st.samplesPlain = pathTrace ? 0 : c.plain;
  st.wavefronts = c.wavefronts;
  if (pathTrace)
  {
    ++AccumFrames;
    st.accumulatedFrames = AccumFrames;
    const float inv = 1.0f / (static_cast<float>(AccumFrames) * static_cast<float>(spp));
    out.rgba.resize(values);
    for (size_t i = 0; i < values; ++i)
      out.rgba[i] = Accum[i] * inv;
  }
  else
  {
    out.rgba.swap(local);
  }
  out.deviceRgba = nullptr;
  st.renderMilliseconds = millis(t1, Clock::now());
  out.stats = st;
  if (deterministic)
  {
    Image = out.rgba;
    ImageKey = key;
    ImageStats = st;
  }
}

} // namespace nv
