// NeuralVolume engine: host side of the GPU renderer -- caches, the three render paths, accumulation, stats.
#include "GpuRenderer.cuh"

#include "Core/Error.h"
#include "GpuRenderInShader.cuh"
#include "GpuRenderKernels.cuh"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <cmath>
#include <vector>

namespace nv
{
namespace gpu
{

namespace
{
uint64_t mixKey(uint64_t a, uint64_t b)
{
  return mix64(a ^ (b * 0x9E3779B97F4A7C15ull));
}

double since(std::chrono::steady_clock::time_point t)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}
} // namespace

// ---------------------------------------------------------------------------------------------------------

void GridTexture::release()
{
  if (TextureObject)
    cudaDestroyTextureObject(TextureObject);
  if (Array)
    cudaFreeArray(Array);
  TextureObject = 0;
  Array = nullptr;
  Bytes = 0;
  Dims[0] = Dims[1] = Dims[2] = 0;
}

void GridTexture::assign(const float* device, int64_t nx, int64_t ny, int64_t nz, cudaStream_t stream)
{
  NV_CHECK(nx >= 1 && ny >= 1 && nz >= 1 && nx <= 16384 && ny <= 16384 && nz <= 16384,
    "decoded grid: 1..16384 samples per axis");
  if (!Array || Dims[0] != nx || Dims[1] != ny || Dims[2] != nz)
  {
    release();
    const cudaChannelFormatDesc desc = cudaCreateChannelDesc<float>();
    const cudaError_t e = cudaMalloc3DArray(&Array, &desc, make_cudaExtent(nx, ny, nz));
    if (e == cudaErrorMemoryAllocation)
    {
      cudaGetLastError();
      Array = nullptr;
      NV_THROW("out of GPU memory for the decoded grid (" + std::to_string(nx) + " x " + std::to_string(ny) + " x " +
        std::to_string(nz) + ")");
    }
    NV_CUDA(e);
    cudaResourceDesc rd{};
    rd.resType = cudaResourceTypeArray;
    rd.res.array.array = Array;
    cudaTextureDesc td{};
    td.filterMode = cudaFilterModeLinear;
    td.addressMode[0] = td.addressMode[1] = td.addressMode[2] = cudaAddressModeClamp;
    td.readMode = cudaReadModeElementType;
    td.normalizedCoords = 0;
    NV_CUDA(cudaCreateTextureObject(&TextureObject, &rd, &td, nullptr));
    Dims[0] = nx;
    Dims[1] = ny;
    Dims[2] = nz;
    Bytes = size_t(nx) * ny * nz * sizeof(float);
  }
  cudaMemcpy3DParms p{};
  p.srcPtr = make_cudaPitchedPtr(const_cast<float*>(device), size_t(nx) * sizeof(float), size_t(nx), size_t(ny));
  p.dstArray = Array;
  p.extent = make_cudaExtent(nx, ny, nz);
  p.kind = cudaMemcpyDeviceToDevice;
  NV_CUDA(cudaMemcpy3DAsync(&p, stream));
}

// ---------------------------------------------------------------------------------------------------------

GpuRenderer::GpuRenderer(const DeviceModel& dm, cudaStream_t stream)
  : Network(dm)
  , RenderStream(stream)
  , Streaming(dm)
{
  Counters.allocate(1, "render counters");
  HostCounters.allocate(1);
  HostScalars.allocate(4);
}

GpuRenderer::~GpuRenderer()
{
  cudaStreamSynchronize(RenderStream);
}

int64_t GpuRenderer::deviceMemoryBytes() const
{
  size_t b = Tf.bytes() + Majorant.bytes() + Lattice.bytes() + GridLinear.bytes() + Depth.bytes() + Range.bytes() +
    Grid.bytes() + Image.bytes() + Accum.bytes() + FrameStart.bytes() + Guide.bytes() + Moments.bytes() +
    SurroundingsValues.bytes();
  b += static_cast<size_t>(Denoiser.deviceMemoryBytes() + Streaming.deviceMemoryBytes());
  return static_cast<int64_t>(b);
}

bool GpuRenderer::prepareGrid(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s)
{
  const int64_t nx = s.gridDims[0], ny = s.gridDims[1], nz = s.gridDims[2];
  const void* source = q.grid ? q.grid->data : nullptr;
  if (Grid.texture() && GridSource == source && GridDims[0] == nx && GridDims[1] == ny && GridDims[2] == nz &&
    (source || fieldStillServes(GridVersion, GridTime, version, q)))
  {
    OlderField |= GridVersion != version && !source;
    return false;
  }
  const int64_t n = nx * ny * nz;
  if (GridLinear.size() < size_t(n))
    GridLinear.allocate(size_t(n), "decoded grid");
  if (q.grid)
  {
    // The reference grid, normalised like the network's output (non-finite values stay NaN: transparent).
    const ValueRange range = model.valueRange(); // ValueRange.h: also for ranges wider than the largest double
    std::vector<float> h(static_cast<size_t>(n));
    for (int64_t i = 0; i < n; ++i)
    {
      const double v = q.grid->at(i);
      h[size_t(i)] = std::isfinite(v) ? static_cast<float>(range.normalize(v)) : std::nanf("");
    }
    NV_CUDA(cudaMemcpyAsync(GridLinear.get(), h.data(), n * sizeof(float), cudaMemcpyHostToDevice, RenderStream));
    NV_CUDA(cudaStreamSynchronize(RenderStream)); // h goes out of scope
  }
  else
  {
    launchInference(Network, nullptr, nx, ny, nz, 0, 0, n, GridLinear.get(), RenderStream);
  }
  Grid.assign(GridLinear.get(), nx, ny, nz, RenderStream);
  GridDims[0] = nx;
  GridDims[1] = ny;
  GridDims[2] = nz;
  GridVersion = version;
  GridSource = source;
  GridTime = std::chrono::steady_clock::now();
  return true;
}

bool GpuRenderer::prepareRanges(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s,
  const uint32_t* occupancy, float background)
{
  RangeKey k;
  int64_t L[3];
  if (q.path == RenderPath::Decode)
  {
    k.kind = 1;
    k.version = GridVersion;
    k.data = GridSource;
    for (int a = 0; a < 3; ++a)
      L[a] = GridDims[a];
  }
  else
  {
    k.kind = 2;
    k.version = version;
    for (int a = 0; a < 3; ++a)
      L[a] = std::max<int64_t>(1, std::min<int64_t>(model.source.dims[a], kMaxLatticeSamples));
  }
  for (int a = 0; a < 3; ++a)
    k.dims[a] = L[a] * 100000 + s.cells.dims[a]; // the cell layout is part of the key
  if (k == Ranges)
    return false;
  RangeKey older = k;
  older.version = Ranges.version;
  if (k.kind == 2 && older == Ranges && fieldStillServes(Ranges.version, RangesTime, version, q))
  {
    OlderField = true; // a live network's ranges, kept for a while (RenderRequest::liveRefreshMilliseconds)
    return false;
  }
  const int cells = s.cells.dims[0] * s.cells.dims[1] * s.cells.dims[2];
  if (Range.size() < size_t(cells))
    Range.allocate(size_t(cells), "macrocell ranges");
  const float* lattice = GridLinear.get();
  float margin = 0.0f;
  if (k.kind == 2)
  {
    const int64_t n = L[0] * L[1] * L[2];
    if (Lattice.size() < size_t(n))
      Lattice.allocate(size_t(n), "macrocell lattice");
    launchInference(Network, nullptr, L[0], L[1], L[2], 0, 0, n, Lattice.get(), RenderStream);
    lattice = Lattice.get();
    margin = kNetworkRangeMargin;
  }
  cellRangeKernel<<<gridFor(cells), 256, 0, RenderStream>>>(s.cells, lattice, L[0], L[1], L[2], margin, occupancy,
    background, Range.get());
  NV_CUDA_LAUNCH();
  Ranges = k;
  RangesTime = std::chrono::steady_clock::now();
  ++RangeStamp;
  return true;
}

bool GpuRenderer::prepareMajorants(const RenderSetup& s, ray::Params& P)
{
  const uint64_t h = mixKey(s.tableKey, RangeStamp);
  const int cells = s.cells.dims[0] * s.cells.dims[1] * s.cells.dims[2];
  const bool work = h != MajorantKey;
  if (work)
  {
    if (Majorant.size() < size_t(cells))
      Majorant.allocate(size_t(cells), "macrocell majorants");
    NV_CUDA(cudaMemsetAsync(&Counters.get()->maxMajorantBits, 0, sizeof(unsigned int), RenderStream));
    majorantKernel<<<gridFor(cells), 256, 0, RenderStream>>>(Range.get(), cells, Tf.get(), P.tfSize, P.tfScale,
      P.tfShift, Majorant.get(), Counters.get());
    NV_CUDA_LAUNCH();
    NV_CUDA(cudaMemcpyAsync(HostScalars.get(), &Counters.get()->maxMajorantBits, sizeof(unsigned int),
      cudaMemcpyDeviceToHost, RenderStream));
    NV_CUDA(cudaStreamSynchronize(RenderStream));
    const uint32_t bits = HostScalars.get()[0];
    std::memcpy(&MaxMajorant, &bits, sizeof(float));
    MajorantKey = h;
  }
  P.majorant = Majorant.get();
  P.maxMajorant = MaxMajorant;
  return work;
}

bool GpuRenderer::uploadMasks(const Model& model, uint64_t version, ray::Params& P)
{
  // A sparse source's occupancy mask and its domain mask, uploaded once per network version.
  bool uploaded = false;
  auto upload = [&](const std::vector<uint32_t>& mask, DeviceBuffer<uint32_t>& buffer, uint64_t& bufferVersion,
                  const char* what) {
    if (bufferVersion == version && buffer.size() == mask.size())
      return;
    if (buffer.size() != mask.size())
      buffer.allocate(mask.size(), what);
    NV_CUDA(cudaMemcpyAsync(buffer.get(), mask.data(), mask.size() * sizeof(uint32_t), cudaMemcpyHostToDevice,
      RenderStream));
    bufferVersion = version;
    uploaded = true;
  };
  if (P.occupancy)
  {
    upload(model.source.occupancy, Occupancy, OccupancyVersion, "occupancy mask");
    P.occupancy = Occupancy.get();
  }
  if (P.domain)
  {
    upload(model.source.domain, Domain, DomainVersion, "domain mask");
    P.domain = Domain.get();
  }
  return uploaded;
}

bool GpuRenderer::prepareSurroundings(const RenderRequest& q, const RenderSetup& s, ray::Params& P)
{
  const bool changed = Surroundings.prepare(q, s, P);
  if (!P.surround)
    return false;
  const std::vector<float>& values = Surroundings.values();
  if (changed || SurroundingsValues.size() < values.size())
  {
    // validate() bounded the grid (kMaxSurroundingsSamples floats).
    if (SurroundingsValues.size() < values.size())
      SurroundingsValues.allocate(values.size(), "surroundings grid");
    NV_CUDA(cudaMemcpyAsync(SurroundingsValues.get(), values.data(), values.size() * sizeof(float),
      cudaMemcpyHostToDevice, RenderStream));
    NV_CUDA(cudaStreamSynchronize(RenderStream)); // the host copy is rewritten when the next grid comes
  }
  P.surround = SurroundingsValues.get();
  return changed;
}

bool GpuRenderer::prepareScene(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s,
  ray::Params& P)
{
  bool work = false;
  OlderField = false;
  if (q.path == RenderPath::Decode)
    work |= prepareGrid(model, version, q, s);
  work |= uploadMasks(model, version, P);
  work |= prepareRanges(model, version, q, s, P.occupancy, P.background);
  if (Tf.size() < s.table.size() || TfKey != s.tableKey)
  {
    // The transfer function, uploaded when it changes (a turning camera keeps it).
    if (Tf.size() < s.table.size())
      Tf.allocate(s.table.size(), "transfer function");
    NV_CUDA(cudaMemcpyAsync(Tf.get(), s.table.data(), s.table.size() * sizeof(float), cudaMemcpyHostToDevice,
      RenderStream));
    NV_CUDA(cudaStreamSynchronize(RenderStream)); // the setup's table is freed when render() returns
    TfKey = s.tableKey;
  }
  P.tf = Tf.get();
  work |= prepareMajorants(s, P);
  work |= prepareSurroundings(q, s, P);
  if (q.depth)
  {
    const int64_t pixels = int64_t(q.width) * q.height;
    if (Depth.size() < size_t(pixels))
      Depth.allocate(size_t(pixels), "depth buffer");
    NV_CUDA(cudaMemcpyAsync(Depth.get(), q.depth, pixels * sizeof(float), cudaMemcpyHostToDevice, RenderStream));
    P.depth = Depth.get();
  }
  return work;
}

void GpuRenderer::traceSamples(const RenderRequest& q, const RenderSetup& s, ray::Params& P, int spp, float4* accum,
  RenderStats& st)
{
  const int64_t pixels = int64_t(q.width) * q.height;
  RenderCounters* c = Counters.get();
  for (int sample = 0; sample < spp; ++sample)
  {
    if (q.path == RenderPath::Decode)
    {
      marchGridKernel<<<gridFor(pixels), 256, 0, RenderStream>>>(P, Grid.texture(), float(GridDims[0] - 1),
        float(GridDims[1] - 1), float(GridDims[2] - 1), static_cast<uint32_t>(sample), Image.get(), accum, c);
      NV_CUDA_LAUNCH();
    }
    else if (q.path == RenderPath::InShader)
    {
      NV_CUDA(cudaMemsetAsync(&c->nextRay, 0, sizeof(unsigned int), RenderStream));
      InShaderArgs a{};
      a.rayParams = P;
      a.total = static_cast<uint32_t>(pixels);
      a.sample = static_cast<uint32_t>(sample);
      a.counters = c;
      a.image = Image.get();
      a.accum = accum;
      launchInShader(Network, a, RenderStream);
    }
    else
    {
      // The wavefront loop runs on the device (no host wait); its graph is rebuilt for a new picture only.
      Streaming.trace(P, s.streamingSamples, static_cast<uint32_t>(sample), Image.get(), accum, c, RenderStream,
        sample == 0, st);
    }
  }
}

void GpuRenderer::prepareGuide(const Model& model, uint64_t version, const RenderRequest& q, uint64_t accumKey,
  RenderStats& st)
{
  if (GuideKey == accumKey && Guide.size() == size_t(Pixels))
    return;
  collectGpuFigures(); // a deferred render's counters, before the guide's trace reuses them
  const auto t0 = std::chrono::steady_clock::now();
  // The emission-absorption picture of the same request: noise-free, the denoiser's colour and alpha.
  const RenderRequest gq = denoiserGuideRequest(q);
  const RenderSetup gs = makeRenderSetup(gq, model.source);
  ray::Params GP = gs.params;
  prepareScene(model, version, gq, gs, GP);
  RenderStats ignored;
  traceSamples(gq, gs, GP, 1, nullptr, ignored);
  if (Guide.size() != size_t(Pixels))
    Guide.allocate(size_t(Pixels), "denoiser guide");
  // (In order on the render stream: nothing waits for the guide here.)
  NV_CUDA(cudaMemcpyAsync(Guide.get(), Image.get(), Guide.bytes(), cudaMemcpyDeviceToDevice, RenderStream));
  GuideKey = accumKey;
  ImageKey = 0; // Image no longer holds the cached ray-marched picture
  st.guideMilliseconds = since(t0);
}

void GpuRenderer::resolveAccumulation(const RenderRequest& q, int spp, RenderStats& st)
{
  Denoiser.addFrameMoments(FrameStart.get(), Accum.get(), Pixels, float(spp), Moments.get(), RenderStream);
  ++Frames;
  Paths += spp;
  resolveKernel<<<gridFor(Pixels), 256, 0, RenderStream>>>(Accum.get(), Pixels, 1.0f / float(Paths), Image.get());
  NV_CUDA_LAUNCH();
  if (!q.denoise)
    return;
  DenoiseParams p;
  p.width = q.width;
  p.height = q.height;
  p.frames = Frames;
  p.paths = float(Paths);
  Denoiser.denoise(p, Image.get(), Guide.get(), Moments.get(), Image.get(), RenderStream);
  st.denoised = true;
}

void GpuRenderer::collectGpuFigures()
{
  if (!FiguresPending)
    return;
  NV_CUDA(cudaEventSynchronize(CountersCopied.get()));
  float ms = 0.0f;
  NV_CUDA(cudaEventElapsedTime(&ms, Begin.get(), End.get()));
  LastGpuFigures.renderMilliseconds = ms;
  LastGpuFigures.samplesEvaluated = static_cast<int64_t>(HostCounters.get()->evaluated);
  LastGpuFigures.samplesPlain = FiguresPathTrace ? 0 : static_cast<int64_t>(HostCounters.get()->plain);
  LastGpuFigures.wavefronts = static_cast<int64_t>(HostCounters.get()->batches);
  float denoiseMs = 0.0f;
  if (FiguresDenoised)
    NV_CUDA(cudaEventElapsedTime(&denoiseMs, Traced.get(), End.get()));
  LastGpuFigures.denoiseMilliseconds = denoiseMs;
  FiguresPending = false;
  NV_CHECK(!HostCounters.get()->truncated, "Sample Streaming: the wavefront loop stopped at its bound of " +
    std::to_string(HostCounters.get()->batches) + " batches with rays still live (the picture is incomplete)");
}

void GpuRenderer::renderImage(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s,
  uint64_t imageKey, RenderStats& st, bool deferred)
{
  ray::Params P = s.params;
  const bool pt = q.shading == ShadingMode::PathTrace || q.shading == ShadingMode::PathTraceNee;
  const int spp = pt ? q.samplesPerPixel : 1;
  const int64_t pixels = int64_t(q.width) * q.height;
  const auto t0 = std::chrono::steady_clock::now();
  if (Pixels != pixels)
  {
    Image.allocate(size_t(pixels), "image");
    Accum.allocate(size_t(pixels), "accumulation");
    Pixels = pixels;
    AccumKey = 0;
    ImageKey = 0;
  }
  const uint64_t key = mixKey(imageKey, 0x5A17ull);
  if (pt && q.denoise)
    prepareGuide(model, version, q, key, st);
  // Decoding and macrocell work is timed to its end; a frame that only turns the camera waits for nothing here.
  if (prepareScene(model, version, q, s, P))
    NV_CUDA(cudaStreamSynchronize(RenderStream));
  st.decodeMilliseconds = since(t0) - st.guideMilliseconds;
  st.olderField = OlderField;

  float4* accum = nullptr;
  if (pt)
  {
    if (FrameStart.size() != size_t(pixels))
    {
      FrameStart.allocate(size_t(pixels), "accumulation frame start");
      Moments.allocate(size_t(pixels), "accumulation moments");
      AccumKey = 0;
    }
    if (!q.accumulate || key != AccumKey)
    {
      NV_CUDA(cudaMemsetAsync(Accum.get(), 0, Accum.bytes(), RenderStream));
      NV_CUDA(cudaMemsetAsync(Moments.get(), 0, Moments.bytes(), RenderStream));
      Frames = 0;
      Paths = 0;
      AccumKey = key;
    }
    NV_CUDA(cudaMemcpyAsync(FrameStart.get(), Accum.get(), Accum.bytes(), cudaMemcpyDeviceToDevice, RenderStream));
    P.frame = static_cast<uint32_t>(Paths);
    accum = Accum.get();
  }
  RenderCounters* c = Counters.get();
  collectGpuFigures(); // a deferred render's figures (done by now, in the usual case), before the counters reset
  NV_CUDA(cudaMemsetAsync(c, 0, sizeof(RenderCounters), RenderStream));
  NV_CUDA(cudaEventRecord(Begin.get(), RenderStream));
  traceSamples(q, s, P, spp, accum, st);
  if (pt)
  {
    NV_CUDA(cudaEventRecord(Traced.get(), RenderStream));
    resolveAccumulation(q, spp, st);
  }
  NV_CUDA(cudaEventRecord(End.get(), RenderStream));
  NV_CUDA(cudaMemcpyAsync(HostCounters.get(), c, sizeof(RenderCounters), cudaMemcpyDeviceToHost, RenderStream));
  NV_CUDA(cudaEventRecord(CountersCopied.get(), RenderStream));
  FiguresPending = true;
  FiguresPathTrace = pt;
  FiguresDenoised = st.denoised;
  // A deferred render returns now (its figures come with the next render); any other waits for its GPU work.
  st.gpuFiguresOfPreviousRender = deferred;
  if (!deferred)
    collectGpuFigures();
  st.renderMilliseconds = LastGpuFigures.renderMilliseconds;
  st.denoiseMilliseconds = LastGpuFigures.denoiseMilliseconds;
  st.samplesEvaluated = LastGpuFigures.samplesEvaluated;
  st.samplesPlain = LastGpuFigures.samplesPlain;
  st.wavefronts = LastGpuFigures.wavefronts;
  st.accumulatedFrames = pt ? Frames : 0;
  st.accumulatedPaths = pt ? Paths : 0;
}

void GpuRenderer::render(const Model& model, uint64_t version, const RenderRequest& q, RenderResult& result,
  Memory where)
{
  const RenderSetup s = makeRenderSetup(q, model.source);
  const bool pt = q.shading == ShadingMode::PathTrace || q.shading == ShadingMode::PathTraceNee;
  const int64_t pixels = int64_t(q.width) * q.height;
  RenderStats st;
  st.path = q.path;
  st.device = Device::Cuda;
  st.rays = pixels * (pt ? q.samplesPerPixel : 1);

  const uint64_t imageKey = mixKey(mixKey(s.key, version), static_cast<uint64_t>(q.path) + 1) | 1ull;
  if (!pt && imageKey == ImageKey && Pixels == pixels)
  {
    st = ImageStats;
    st.reused = true;
    st.decodeMilliseconds = st.renderMilliseconds = 0.0;
  }
  else
  {
    renderImage(model, version, q, s, imageKey, st, where == Memory::Device && q.deferDeviceSync);
    if (!pt)
    {
      // A picture of an older field is not the version's picture: Image holds nothing to reuse then.
      ImageKey = st.olderField ? 0 : imageKey;
      ImageStats = st;
    }
    else
      ImageKey = 0; // Image holds the path-traced picture now
  }

  if (where == Memory::Device)
  {
    result.rgba.clear();
    result.deviceRgba = reinterpret_cast<const float*>(Image.get());
    result.deviceReady = st.gpuFiguresOfPreviousRender ? static_cast<const void*>(End.get()) : nullptr;
  }
  else
  {
    const auto copyStart = std::chrono::steady_clock::now();
    result.rgba.resize(size_t(pixels) * 4);
    NV_CUDA(cudaMemcpyAsync(result.rgba.data(), Image.get(), pixels * sizeof(float4), cudaMemcpyDeviceToHost,
      RenderStream));
    NV_CUDA(cudaStreamSynchronize(RenderStream));
    st.hostCopyMilliseconds = since(copyStart);
    result.deviceRgba = nullptr;
    result.deviceReady = nullptr;
  }
  result.stats = st;
}

} // namespace gpu
} // namespace nv
