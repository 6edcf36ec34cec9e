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
  const RenderRequest& q, bool& older)
{
  const RenderControl* control = q.control;
  int64_t dims[3];
  for (int a = 0; a < 3; ++a)
    dims[a] = std::max<int64_t>(1, std::min<int64_t>(model.source.dims[a], Options.latticeMax));
  if (Lattice && Lattice->dims[0] == dims[0] && Lattice->dims[1] == dims[1] && Lattice->dims[2] == dims[2] &&
    fieldStillServes(Lattice->version, Lattice->decodedAt, version, q))
  {
    older = Lattice->version != version;
    return Lattice;
  }
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
    resetAccumulation();
    NV_THROW("out of memory rendering a " + std::to_string(q.width) + " x " + std::to_string(q.height) + " image (" +
      renderPathName(q.path) + ", " + shadingModeName(q.shading) + ")");
  }
}

/// One render's state, from its setup to its image (renderImpl's steps share it).
struct CpuRenderer::Frame
{
  RenderSetup setup;
  RenderStats stats;
  std::shared_ptr<const DecodedGrid> grid;    ///< Decode: the grid the rays sample
  std::shared_ptr<const DecodedGrid> lattice; ///< the field the macrocells' ranges come from
  Clock::time_point start, fieldReady;       ///< the render's start; the field and its macrocells ready
  bool pathTrace = false;
  bool deterministic = false; ///< not an accumulation: the image is kept for an identical request
  uint64_t key = 0;           ///< the picture's key: the setup's, the network version, the lattice
  size_t values = 0;          ///< floats of the image (width * height * 4)
  int spp = 1;
  bool denoise = false;       ///< path tracing with request.denoise: the image handed out is filtered
  std::vector<float> local;   ///< the image of a render that does not accumulate
  float* target = nullptr;    ///< where the trace adds its paths: `local` or the accumulation
  TraceCounters counters;
};

namespace
{
/// A cancelled render's result: no image.
void setCancelled(RenderResult& out, RenderPath path)
{
  out.rgba.clear();
  out.deviceRgba = nullptr;
  out.stats = RenderStats();
  out.stats.path = path;
  out.stats.cancelled = true;
}
} // namespace

void CpuRenderer::renderImpl(const Model& model, uint64_t version, const RenderRequest& q, RenderResult& out)
{
  const Clock::time_point t0 = Clock::now();
  NV_CHECK(model.paramCount() > 0 && model.paramCount() == model.encodingParamCount() + model.mlpParamCount(),
    "the model has no parameters");
  if (q.grid && q.path != RenderPath::Decode)
    NV_THROW(std::string("invalid render request: a reference grid is rendered by the Decode path only (path is ") +
      renderPathName(q.path) + ")");
  if (q.control && q.control->cancel.load())
  {
    setCancelled(out, q.path);
    return;
  }
  Frame f{ makeRenderSetup(q, model.source) };
  f.start = t0;
  DecodeShown = q.path == RenderPath::Decode && !q.grid;
  f.stats.path = q.path;
  f.stats.device = Device::Cpu;

  // 1. The field and its macrocells.
  if (!prepareField(model, version, q, f))
  {
    setCancelled(out, q.path);
    return;
  }
  f.fieldReady = Clock::now();
  f.stats.decodeMilliseconds = millis(f.start, f.fieldReady);

  // 2. An identical deterministic request returns the previous image.
  f.pathTrace = q.shading == ShadingMode::PathTrace || q.shading == ShadingMode::PathTraceNee;
  f.key = combine(combine(f.setup.key, version), f.lattice->id);
  f.values = static_cast<size_t>(q.width) * static_cast<size_t>(q.height) * 4;
  f.deterministic = !f.pathTrace || !q.accumulate;
  if (f.deterministic && deterministicKey(q, f) == ImageKey && Image.size() == f.values)
  {
    out.rgba = Image;
    out.deviceRgba = nullptr;
    out.stats = ImageStats;
    out.stats.reused = true;
    out.stats.decodeMilliseconds = f.stats.decodeMilliseconds;
    out.stats.renderMilliseconds = millis(f.fieldReady, Clock::now());
    return;
  }

  // 3. The denoiser's guide (path tracing, once per picture); 4. where the paths go; 5. trace; 6. the image.
  f.denoise = f.pathTrace && q.denoise;
  if (f.denoise && !prepareGuide(model, version, q, f))
  {
    setCancelled(out, q.path);
    return;
  }
  chooseTarget(q, f);
  trace(model, version, q, f);
  finishImage(q, f, out);
}

uint64_t CpuRenderer::deterministicKey(const RenderRequest& q, const Frame& f)
{
  // A path-traced image that does not accumulate depends on its paths per pixel too (not in the picture's key).
  return f.pathTrace ? combine(f.key, static_cast<uint64_t>(q.samplesPerPixel)) : f.key;
}

void CpuRenderer::resetAccumulation()
{
  Accum.clear();
  Moments.clear();
  AccumFrames = 0;
  AccumPaths = 0;
}

bool CpuRenderer::prepareGuide(const Model& model, uint64_t version, const RenderRequest& q, Frame& f)
{
  if (GuideKey == f.key && Guide.size() == f.values)
    return true;
  const Clock::time_point t0 = Clock::now();
  // The emission-absorption picture of the same request and field: noise-free, the denoiser's colour and alpha.
  const RenderRequest gq = denoiserGuideRequest(q);
  Frame g{ makeRenderSetup(gq, model.source) };
  g.grid = f.grid;
  g.lattice = f.lattice;
  g.values = f.values;
  bindField(gq, g);
  chooseTarget(gq, g);
  trace(model, version, gq, g);
  bindField(q, f); // the path tracer's majorants again (the same unless the tables differ)
  if (g.counters.cancelled)
    return false;
  Guide.swap(g.local);
  GuideKey = f.key;
  f.stats.guideMilliseconds = millis(t0, Clock::now());
  return true;
}

bool CpuRenderer::prepareField(const Model& model, uint64_t version, const RenderRequest& q, Frame& f)
{
  // The grid itself for Decode (exact ranges), a lattice of the network otherwise (ranges widened by network probes
  // inside each cell).
  RenderSetup& setup = f.setup;
  if (q.path == RenderPath::Decode)
  {
    if (q.grid)
      f.grid = referenceGrid(model, *q.grid);
    else
    {
      // A live network's last full grid stands in for a while (RenderRequest::liveRefreshMilliseconds).
      std::shared_ptr<const DecodedGrid> last = Decoder.lastFull(setup.gridDims);
      if (last && last->version != version && !q.waitForDecode &&
        fieldStillServes(last->version, last->decodedAt, version, q))
      {
        f.grid = last;
        f.stats.olderField = true;
      }
      else
      {
        const CpuGridDecoder::Result a = Decoder.acquire(model, version, setup.gridDims, q.waitForDecode);
        f.grid = a.grid;
        f.stats.decodePending = a.pending;
      }
    }
    f.lattice = f.grid;
    const DecodedGrid& lattice = *f.lattice;
    Cells.updateRanges(Pool, setup.cells, lattice.values.data(), lattice.dims, lattice.id);
  }
  else
  {
    f.lattice = networkLattice(model, version, q, f.stats.olderField);
    if (!f.lattice)
      return false;
    const DecodedGrid& lattice = *f.lattice;
    const int64_t cells = int64_t(setup.cells.dims[0]) * setup.cells.dims[1] * setup.cells.dims[2];
    const CpuInference net(model);
    if (Options.probesPerCell > 0)
    {
      const int probes = static_cast<int>(std::max<int64_t>(4, std::min<int64_t>(Options.probesPerCell,
        Options.maxProbes / cells)));
      Cells.updateRanges(Pool, setup.cells, lattice.values.data(), lattice.dims, lattice.id, 0.0f, &net, probes);
    }
    else
      Cells.updateRanges(Pool, setup.cells, lattice.values.data(), lattice.dims, lattice.id, kNetworkRangeMargin);
  }
  bindField(q, f);
  return true;
}

void CpuRenderer::bindField(const RenderRequest& q, Frame& f)
{
  ray::Params& P = f.setup.params;
  if (P.occupancy)
    Cells.setEmptyCells(P.occupancy, P.background);
  Cells.updateMajorants(Pool, f.setup.table.data(), P.tfSize, P.tfScale, P.tfShift, f.setup.tableKey);
  P.tf = f.setup.table.data();
  P.majorant = Cells.majorants();
  P.maxMajorant = Cells.maxMajorant();
  P.depth = q.depth;
  Surroundings.prepare(q, f.setup, P);
}

void CpuRenderer::chooseTarget(const RenderRequest& q, Frame& f)
{
  // Path tracing continues the accumulation while nothing changed; every path has its own frame index.
  int64_t frame = 0;
  f.spp = f.pathTrace ? q.samplesPerPixel : 1;
  if (f.pathTrace)
  {
    if (!(q.accumulate && f.key == AccumKey && Accum.size() == f.values && AccumFrames > 0))
    {
      Accum.assign(f.values, 0.0f);
      Moments.assign(f.values / 4, 0.0f);
      AccumFrames = 0;
      AccumPaths = 0;
      AccumKey = f.key;
    }
    frame = AccumPaths;
    FrameStart = Accum; // the frame's own sums are the difference (the denoiser's moments)
    f.target = Accum.data();
  }
  else
  {
    f.local.assign(f.values, 0.0f);
    f.target = f.local.data();
  }
  // path s of this render: P.frame + s
  f.setup.params.frame = static_cast<uint32_t>(frame);
}

void CpuRenderer::trace(const Model& model, uint64_t version, const RenderRequest& q, Frame& f)
{
  // The same machine, three ways of evaluating its queries.
  const ray::Params& P = f.setup.params;
  try
  {
    switch (q.path)
    {
      case RenderPath::Decode:
      {
        const CpuGridSampler sampler(f.grid->values.data(), f.grid->dims, f.grid->hasNaN);
        traceDecode(Pool, P, f.spp, sampler, f.target, q.control, f.counters);
        break;
      }
      case RenderPath::InShader:
      {
        HalfTable.update(model, version);
        const CpuHalfNetwork net(model, HalfTable.table());
        traceInShader(Pool, P, f.spp, net, f.target, q.control, f.counters);
        break;
      }
      case RenderPath::SampleStreaming:
      {
        const CpuInference net(model);
        traceStreaming(Pool, P, f.spp, f.setup.streamingSamples, net, f.target, q.control, f.counters);
        break;
      }
    }
  }
  catch (...)
  {
    // A partial frame would corrupt the accumulation: start over next time.
    resetAccumulation();
    throw;
  }
  f.stats.rays = static_cast<int64_t>(q.width) * q.height * f.spp;
  f.stats.samplesEvaluated = f.counters.evaluated;
}

void CpuRenderer::finishImage(const RenderRequest& q, Frame& f, RenderResult& out)
{
  RenderStats& st = f.stats;
  const TraceCounters& c = f.counters;
  if (c.cancelled)
  {
    // Stopped by the caller: nothing is cached, a partial path-tracing frame is not averaged in.
    if (f.pathTrace)
      resetAccumulation();
    st.cancelled = true;
    st.wavefronts = c.wavefronts;
    st.renderMilliseconds = millis(f.fieldReady, Clock::now());
    out.rgba.clear();
    out.deviceRgba = nullptr;
    out.stats = st;
    return;
  }
  st.samplesPlain = f.pathTrace ? 0 : c.plain;
  st.wavefronts = c.wavefronts;
  if (f.pathTrace)
    resolveAccumulation(q, f, out);
  else
  {
    out.rgba.swap(f.local);
  }
  out.deviceRgba = nullptr;
  st.renderMilliseconds = millis(f.fieldReady, Clock::now());
  out.stats = st;
  if (f.deterministic)
  {
    Image = out.rgba;
    ImageKey = deterministicKey(q, f);
    ImageStats = st;
  }
}

void CpuRenderer::resolveAccumulation(const RenderRequest& q, Frame& f, RenderResult& out)
{
  RenderStats& st = f.stats;
  const int64_t pixels = static_cast<int64_t>(f.values / 4);
  const float framePaths = static_cast<float>(f.spp);
  Pool.parallelFor(pixels, [&](int64_t b, int64_t e, int) {
    for (int64_t i = b; i < e; ++i)
      denoise::addFrameMoment(&FrameStart[4 * i], &Accum[4 * i], framePaths, Moments[i]);
  });
  ++AccumFrames;
  AccumPaths += f.spp;
  st.accumulatedFrames = AccumFrames;
  st.accumulatedPaths = AccumPaths;
  const float inv = 1.0f / static_cast<float>(AccumPaths);
  out.rgba.resize(f.values);
  for (size_t i = 0; i < f.values; ++i)
    out.rgba[i] = Accum[i] * inv;
  if (!f.denoise)
    return;
  const Clock::time_point t0 = Clock::now();
  DenoiseParams p;
  p.width = q.width;
  p.height = q.height;
  p.frames = AccumFrames;
  p.paths = static_cast<float>(AccumPaths);
  Denoised.resize(f.values);
  Denoiser.denoise(Pool, p, out.rgba.data(), Guide.data(), Moments.data(), Denoised.data());
  out.rgba.swap(Denoised);
  st.denoised = true;
  st.denoiseMilliseconds = millis(t0, Clock::now());
}

} // namespace nv
