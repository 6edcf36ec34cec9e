// The GPU renderer against the CPU renderer (the oracle: the same ray machine, macrocells made the GPU's way), the
// GPU paths against each other, empty-space skipping, accumulation, device-memory output and a real volume
// (ray marching of the network vs the same marcher on the original data). Label gpu: skipped without a GPU.
//   nvTestGpuRender [case] [--data DIR] [kernel flags]
#include "Core/EngineWarnings.h"
#include "Core/Macrocells.h"
#include "Cpu/CpuDenoiser.h"
#include "DenoiseFixtures.h"
#include "Core/NetworkSession.h"
#include "Core/RenderSetup.h"
#include "Cpu/CpuRenderer.h"
#include "Cpu/ThreadPool.h"
#include "Gpu/GpuEngine.h"
#include "GpuTestHooks.h"
#include "KernelFlags.h"
#include "Nhdr.h"
#include "RenderFixtures.h"
#include "RenderSetupBench.h"
#include "SurroundingsFixtures.h"
#include "TestHarness.h"

#include <cstdio>
#include <array>
#include <cstring>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

using namespace nv;
using namespace nvtest;

namespace
{
constexpr int kSkip = 77;
constexpr int kGrid = 40;
const char* kPath[] = { "Decode", "Streaming", "In-Shader" };
const char* kMode[] = { "RM", "RM+grad", "RM+shadow", "PT", "PT+NEE" };

std::string& dataDir()
{
  static std::string d;
  return d;
}
KernelOptions& kernels()
{
  static KernelOptions k;
  return k;
}

ThreadPool& pool()
{
  static ThreadPool p(0);
  return p;
}

struct Scene
{
  std::vector<float> data = blobVolume(kGrid);
  VolumeView volume = viewOf(data, kGrid, kGrid, kGrid);
  Model model = trainModel(volume, smallRenderConfig(), 300, 4096);
};
Scene& scene()
{
  static Scene s;
  return s;
}

/// The CPU oracle with the GPU's macrocells (fixed margin, the same lattice).
CpuRenderer& oracle(int path)
{
  static std::unique_ptr<CpuRenderer> r[3];
  if (!r[path])
  {
    CpuRendererOptions o;
    o.probesPerCell = 0;
    o.latticeMax = static_cast<int>(kMaxLatticeSamples);
    r[path] = std::make_unique<CpuRenderer>(pool(), o);
  }
  return *r[path];
}

std::unique_ptr<NetworkSession> gpuSession(const Model& m, bool halfAccumulate)
{
  SessionOptions o;
  o.kernels = kernels();
  o.kernels.inShaderHalfAccumulate = halfAccumulate;
  return NetworkSession::create(Device::Cuda, m, o);
}

/// Path tracing is compared on converged images (one path traced with two seeds is ~22 dB apart at 256 spp).
RenderRequest request(int path, int mode, int size)
{
  RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode(mode), size, size);
  q.samplesPerPixel = mode >= 3 ? 512 : 1;
  return q;
}
} // namespace

NV_TEST(gpu_matches_cpu_every_path_and_mode)
{
  // Ray marching at 64 x 64; path tracing at 24 x 24 and 512 paths per pixel. The thresholds leave room for the
  // GPU's fp16 table and activations (Decode, Streaming; the CPU oracle's decode is fp32), the texture unit's
  // 8-bit interpolation weights (Decode) and fp16 accumulation (In-Shader by default).
  const double minRm[3] = { 38.0, 38.0, 38.0 }, minPt = 30.0;
  auto gpu = gpuSession(scene().model, true);
  auto gpu32 = gpuSession(scene().model, false);
  for (int p = 0; p < 3; ++p)
    for (int m = 0; m < 5; ++m)
    {
      const RenderRequest q = request(p, m, m >= 3 ? 24 : 64);
      RenderResult c, g;
      oracle(p).render(scene().model, 1, q, c);
      gpu->render(q, g, Memory::Host);
      const double db = psnr(g.rgba, c.rgba);
      std::printf("    %-9s %-9s GPU vs CPU %.1f dB (evaluated %lld / %lld, plain %lld / %lld)\n", kPath[p], kMode[m], db,
        (long long)g.stats.samplesEvaluated, (long long)c.stats.samplesEvaluated, (long long)g.stats.samplesPlain,
        (long long)c.stats.samplesPlain);
      EXPECT_TRUE(allFinite(g.rgba));
      EXPECT_TRUE(db >= (m >= 3 ? minPt : minRm[p]));
      EXPECT_TRUE(g.stats.device == Device::Cuda && g.stats.path == RenderPath(p));
      if (p == 2)
      {
        // fp32 accumulation: the CPU oracle's numerics.
        RenderResult g32;
        gpu32->render(q, g32, Memory::Host);
        const double db32 = psnr(g32.rgba, c.rgba), dbAcc = psnr(g32.rgba, g.rgba);
        std::printf("    %-9s %-9s fp32-accumulating In-Shader vs CPU %.1f dB, vs fp16-accumulating %.1f dB\n",
          kPath[p], kMode[m], db32, dbAcc);
        EXPECT_TRUE(db32 >= (m >= 3 ? minPt : 45.0));
      }
    }
}

NV_TEST(gpu_in_shader_fits_smaller_shared_memory)
{
  // A network whose In-Shader staging at 8 warps per block exceeds Turing's 64 KiB of shared memory per block.
  // Forced to that limit (KernelOptions::sharedMemoryLimit), the kernel runs fewer warps per block; every ray is
  // evaluated by its own lane either way, so the picture is the same bit for bit. At 16 KiB nothing fits: a clear
  // error naming the other paths.
  ModelConfig c = smallRenderConfig();
  c.network.width = 64;
  c.network.hiddenLayers = 5;
  const Model m = trainModel(scene().volume, c, 200, 4096, 3, 0);
  const RenderRequest q = blobRequest(m, RenderPath::InShader, ShadingMode(0), 64, 64);
  auto session = [&](int limit) {
    SessionOptions o;
    o.kernels = kernels();
    o.kernels.sharedMemoryLimit = limit;
    return NetworkSession::create(Device::Cuda, m, o);
  };
  RenderResult full, turing, cpu;
  session(0)->render(q, full, Memory::Host);
  session(65536)->render(q, turing, Memory::Host);
  oracle(2).render(m, 1, q, cpu);
  const double db = psnr(full.rgba, cpu.rgba);
  std::printf("    In-Shader, width 64 x 5 layers: GPU vs CPU %.1f dB; 64 KiB limit identical: %s\n", db,
    full.rgba == turing.rgba ? "yes" : "no");
  EXPECT_TRUE(allFinite(full.rgba) && db >= 38.0);
  EXPECT_TRUE(full.rgba == turing.rgba);
  bool clear = false;
  try
  {
    RenderResult none;
    session(16384)->render(q, none, Memory::Host);
  }
  catch (const std::exception& e)
  {
    clear = std::strstr(e.what(), "too large for In-Shader rendering") != nullptr;
    std::printf("    16 KiB: %s\n", e.what());
  }
  EXPECT_TRUE(clear);
}

namespace
{
/// Every GPU path and shading mode, viewed orthographically along -z: the pixels right of x = 0.5 + margin stay empty
/// (alpha exactly 0) where the network `plain` draws there, and the picture agrees with the CPU oracle's.
void expectRightHalfEmpty(const char* what, const Model& model, const Model& plain, double clipXHi, double margin,
  uint64_t seed)
{
  auto gpu = gpuSession(model, false);
  auto plainGpu = gpuSession(plain, false);
  for (int p = 0; p < 3; ++p)
    for (int m = 0; m < 5; ++m)
    {
      const int w = m >= 3 ? 24 : 48, h = m >= 3 ? 20 : 40;
      RenderRequest q = blobRequest(model, RenderPath(p), ShadingMode(m), w, h);
      q.samplesPerPixel = m >= 3 ? 256 : 1;
      setCamera(q, orthoAlongZ());
      RenderResult g0;
      plainGpu->render(q, g0, Memory::Host);
      q.clipBox[1] = clipXHi;
      RenderResult g, cpu;
      gpu->render(q, g, Memory::Host);
      oracle(p).render(model, seed, q, cpu);
      int64_t lit = 0, plainLit = 0, pixels = 0;
      for (int py = 0; py < h; ++py)
        for (int px = 0; px < w; ++px)
        {
          const double ux = (-1.2 + 2.4 * (px + 0.5) / w + 1.0) / 2.0;
          if (ux <= 0.5 + margin)
            continue;
          const size_t k = 4 * (size_t(py) * w + px);
          ++pixels;
          lit += g.rgba[k + 3] != 0.0f ? 1 : 0;
          plainLit += g0.rgba[k + 3] > 0.01f ? 1 : 0;
        }
      const double db = psnr(g.rgba, cpu.rgba);
      std::printf("    %-9s %-9s %s: %lld of %lld pixels beyond x = 0.5 lit (%lld without it); GPU vs CPU %.1f dB\n",
        kPath[p], kMode[m], what, (long long)lit, (long long)pixels, (long long)plainLit, db);
      EXPECT_TRUE(pixels > 0 && lit == 0 && plainLit > 0);
      EXPECT_TRUE(allFinite(g.rgba) && db >= (m >= 3 ? 30.0 : 38.0));
    }
}
} // namespace

NV_TEST(gpu_draws_nothing_outside_the_domain)
{
  // The domain mask of a resampled source (here the half x < 0.5 of the box).
  Model masked = scene().model;
  keepHalfX(masked);
  expectRightHalfEmpty("masked", masked, scene().model, 1.0, 1.0 / double(masked.source.dims[0] - 1), 7);
}

NV_TEST(gpu_clip_box_matches_cpu_and_draws_nothing_beyond_it)
{
  // RenderRequest::clipBox (MPI: a rank draws only its own block of a network trained with ghost layers): x < 0.5.
  expectRightHalfEmpty("clipped", scene().model, scene().model, 0.5, 0.02, 13);
}

NV_TEST(gpu_surroundings_match_cpu)
{
  // RenderRequest::surroundings (MPI: shadows and path tracing across pieces): the half x < 0.5 of the network lit
  // from +x, its secondary rays continuing through a coarse grid of the whole blob beyond the clip box. The GPU's
  // picture must match the CPU oracle's with the grid, and be nearer to it than to the CPU's without the grid (the
  // shadow of the other half is there). Every path; shadows, path tracing and path tracing + NEE.
  const double unitBox[6] = { 0, 1, 0, 1, 0, 1 };
  const std::shared_ptr<const SurroundingsGrid> grid = coarseSurroundings(unitBox, 25);
  auto gpu = gpuSession(scene().model, false);
  for (int p = 0; p < 3; ++p)
    for (int m = 2; m < 5; ++m)
    {
      RenderRequest q = request(p, m, m >= 3 ? 24 : 64);
      q.clipBox[1] = 0.5;
      RenderResult without, c, g;
      oracle(p).render(scene().model, 1, q, without);
      q.surroundings = grid;
      oracle(p).render(scene().model, 1, q, c);
      gpu->render(q, g, Memory::Host);
      const double db = psnr(g.rgba, c.rgba), dbWithout = psnr(g.rgba, without.rgba);
      std::printf("    %-9s %-9s surroundings: GPU vs CPU %.1f dB, vs CPU without them %.1f dB\n", kPath[p], kMode[m], db,
        dbWithout);
      EXPECT_TRUE(allFinite(g.rgba) && db >= (m >= 3 ? 30.0 : 38.0));
      EXPECT_TRUE(db >= dbWithout + 3.0);
    }
}

NV_TEST(gpu_empty_cells_of_a_sparse_source_are_its_background)
{
  // A sparse source's occupancy (the macrocells of the half x >= 0.5 hold the background, here the field's minimum:
  // transparent) on every GPU path and the five shading modes: pixels over the empty half stay empty (alpha exactly
  // 0, where the plain network draws), the picture agrees with the CPU oracle's, and ray marching evaluates fewer
  // samples than without the mask.
  Model sparse = scene().model;
  occupyHalfX(sparse, sparse.source.valueMin);
  const MacrocellLayout cells = macrocellLayout(sparse.source.dims);
  const double firstEmpty = double(cells.dims[0] / 2) / cells.scale[0];
  auto gpu = gpuSession(sparse, false);
  auto plain = gpuSession(scene().model, false);
  const Mat4 vp = orthoAlongZ();
  for (int p = 0; p < 3; ++p)
    for (int m = 0; m < 5; ++m)
    {
      const int w = m >= 3 ? 24 : 48, h = m >= 3 ? 20 : 40;
      RenderRequest q = blobRequest(sparse, RenderPath(p), ShadingMode(m), w, h);
      q.samplesPerPixel = m >= 3 ? 256 : 1;
      setCamera(q, vp);
      RenderResult g, cpu, g0;
      gpu->render(q, g, Memory::Host);
      plain->render(q, g0, Memory::Host);
      oracle(p).render(sparse, 11, q, cpu);
      int64_t emptyLit = 0, emptyPlain = 0;
      for (int py = 0; py < h; ++py)
        for (int px = 0; px < w; ++px)
        {
          const double ux = (-1.2 + 2.4 * (px + 0.5) / w + 1.0) / 2.0;
          if (ux <= firstEmpty + 0.02 || ux >= 1.0)
            continue;
          const size_t k = 4 * (size_t(py) * w + px);
          emptyLit += g.rgba[k + 3] != 0.0f ? 1 : 0;
          emptyPlain += g0.rgba[k + 3] > 0.01f ? 1 : 0;
        }
      const double db = psnr(g.rgba, cpu.rgba);
      std::printf("    %-9s %-9s sparse: %lld empty-half pixels lit (%lld without the mask); GPU vs CPU %.1f dB; "
                  "evaluated %lld (plain network %lld)\n", kPath[p], kMode[m], (long long)emptyLit, (long long)emptyPlain,
        db, (long long)g.stats.samplesEvaluated, (long long)g0.stats.samplesEvaluated);
      EXPECT_TRUE(emptyLit == 0 && emptyPlain > 0);
      EXPECT_TRUE(allFinite(g.rgba) && db >= (m >= 3 ? 30.0 : 38.0));
      if (m < 3)
        EXPECT_TRUE(g.stats.samplesEvaluated < g0.stats.samplesEvaluated);
    }
}

NV_TEST(gpu_paths_agree_but_are_not_identical)
{
  auto gpu = gpuSession(scene().model, true);
  for (int m = 0; m < 5; ++m)
  {
    RenderResult r[3];
    for (int p = 0; p < 3; ++p)
      gpu->render(request(p, m, m >= 3 ? 24 : 64), r[p], Memory::Host);
    const double ds = psnr(r[0].rgba, r[1].rgba), di = psnr(r[0].rgba, r[2].rgba), si = psnr(r[1].rgba, r[2].rgba);
    std::printf("    %-9s Decode vs Streaming %.1f dB, Decode vs In-Shader %.1f dB, Streaming vs In-Shader %.1f dB\n",
      kMode[m], ds, di, si);
    EXPECT_TRUE(ds >= 30.0 && di >= 30.0 && si >= 30.0);
    EXPECT_TRUE(r[0].rgba != r[1].rgba && r[0].rgba != r[2].rgba && r[1].rgba != r[2].rgba);
    // Each path ran its own code: only Sample Streaming has wavefronts.
    EXPECT_TRUE(r[0].stats.wavefronts == 0 && r[1].stats.wavefronts > 0 && r[2].stats.wavefronts == 0);
    for (int p = 0; p < 3; ++p)
      EXPECT_TRUE(r[p].stats.samplesEvaluated > 0);
  }
}

NV_TEST(gpu_streaming_loop_runs_on_the_device_in_any_batch_size)
{
  // The wavefront loop runs on the device (a CUDA graph; CUDA >= 12.4): no host wait inside. Batches of 2048 queries
  // (several per wavefront; Morton-binned, 8^3 bins) give the picture of one unbinned batch per wavefront bit for bit.
  auto whole = gpuSession(scene().model, true);
  SessionOptions o;
  o.kernels = kernels();
  o.kernels.streamBatchQueries = 2048;
  o.kernels.binBitsPerAxis = 3;
  auto small = NetworkSession::create(Device::Cuda, scene().model, o);
  for (int m = 0; m < 5; ++m)
  {
    RenderRequest q = request(1, m, m >= 3 ? 24 : 48);
    q.samplesPerPixel = m >= 3 ? 8 : 1;
    RenderResult a, b;
    whole->render(q, a, Memory::Host);
    small->render(q, b, Memory::Host);
    std::printf("    %-9s batches %lld vs %lld (2048 queries each); host waits %lld, %lld; identical %s\n", kMode[m],
      (long long)a.stats.wavefronts, (long long)b.stats.wavefronts, (long long)a.stats.wavefrontHostSyncs,
      (long long)b.stats.wavefrontHostSyncs, a.rgba == b.rgba ? "yes" : "no");
    for (const std::string& w : takeWarnings())
      std::printf("    warning: %s\n", w.c_str()); // why the loop fell back to the host, if it did
    EXPECT_TRUE(a.stats.wavefrontHostSyncs == 0 && b.stats.wavefrontHostSyncs == 0);
    EXPECT_TRUE(a.stats.wavefronts > 0 && b.stats.wavefronts > a.stats.wavefronts);
    EXPECT_TRUE(a.stats.samplesEvaluated == b.stats.samplesEvaluated && a.stats.samplesPlain == b.stats.samplesPlain);
    EXPECT_TRUE(allFinite(a.rgba) && a.rgba == b.rgba);
  }
}

NV_TEST(gpu_skipping_does_not_change_the_picture)
{
  auto gpu = gpuSession(scene().model, true);
  for (int p = 0; p < 3; ++p)
  {
    RenderRequest q = request(p, 0, 64);
    RenderResult on, off;
    gpu->render(q, on, Memory::Host);
    q.emptySpaceSkipping = false;
    gpu->render(q, off, Memory::Host);
    const double db = psnr(on.rgba, off.rgba);
    const double ratio = double(on.stats.samplesEvaluated) / double(off.stats.samplesEvaluated);
    std::printf("    %-9s skipping on vs off %.1f dB, samples evaluated %.3f of the plain marcher's\n", kPath[p], db,
      ratio);
    EXPECT_TRUE(db >= 45.0);
    EXPECT_TRUE(ratio < 0.9);
    // Without skipping, one sample per step up to termination -- Sample Streaming also evaluates the rest of the
    // last K-step batch of a ray that terminated early (at most K - 1 per ray).
    const int64_t extra = off.stats.samplesEvaluated - off.stats.samplesPlain;
    std::printf("    %-9s without skipping: %lld samples beyond the plain marcher's\n", kPath[p], (long long)extra);
    if (p == 1)
      EXPECT_TRUE(extra >= 0 && extra <= int64_t(kDefaultStreamingSamples - 1) * off.stats.rays);
    else
      EXPECT_TRUE(extra == 0);
  }
}

NV_TEST(gpu_accumulation_and_device_output)
{
  auto gpu = gpuSession(scene().model, true);
  RenderRequest q = request(2, 4, 32);
  q.samplesPerPixel = 4;
  RenderResult a, b, c;
  gpu->render(q, a, Memory::Host);
  gpu->render(q, b, Memory::Host);
  q.lightDirection[0] = -0.6;
  gpu->render(q, c, Memory::Host);
  std::printf("    accumulated frames %d, %d, after a change %d\n", a.stats.accumulatedFrames, b.stats.accumulatedFrames,
    c.stats.accumulatedFrames);
  EXPECT_TRUE(a.stats.accumulatedFrames == 1 && b.stats.accumulatedFrames == 2 && c.stats.accumulatedFrames == 1);
  EXPECT_TRUE(a.rgba != b.rgba);
  // Ray marching: an unchanged request is not rendered again; the device image equals the host one.
  RenderRequest r = request(0, 1, 48);
  RenderResult h, d, again;
  gpu->render(r, h, Memory::Host);
  gpu->render(r, again, Memory::Host);
  EXPECT_TRUE(!h.stats.reused && again.stats.reused && again.rgba == h.rgba);
  r.lightDirection[2] = -0.4;
  gpu->render(r, d, Memory::Device);
  EXPECT_TRUE(d.deviceRgba != nullptr && d.rgba.empty() && !d.stats.reused);
  std::vector<float> copy(size_t(48) * 48 * 4);
  gpu::copyToHost(d.deviceRgba, copy.size(), copy.data());
  RenderResult hd;
  gpu->render(r, hd, Memory::Host); // the same request: reused, copied to the host
  EXPECT_TRUE(hd.stats.reused && hd.rgba == copy);
}

NV_TEST(gpu_denoiser_matches_cpu)
{
  // The same input through the CUDA kernels and the CPU loop (one shared per-pixel math, Core/Denoise.h): equal
  // within 1e-3 (the CUDA build's fast exp and square root), and both within 1e-3 of the double-precision version.
  const double tolerance = 1e-3;
  for (int frames : { 1, 8, 40 })
  {
    const DenoiseInput in = syntheticDenoiseInput(97, 61, frames, 11);
    std::vector<float> cpu(in.noisy.size()), gpu(in.noisy.size());
    CpuDenoiser d;
    d.denoise(pool(), in.params, in.noisy.data(), in.guide.data(), in.moments.data(), cpu.data());
    gpu::testDenoise(in.params, in.noisy.data(), in.guide.data(), in.moments.data(), gpu.data());
    const std::vector<double> ref = referenceDenoise(in), cpuD(cpu.begin(), cpu.end());
    const double gpuCpu = maxDifference(gpu, cpuD), gpuRef = maxDifference(gpu, ref);
    std::printf("    %d frame(s): max |GPU - CPU| %.2e, |GPU - double| %.2e (tolerance %.0e)\n", frames, gpuCpu,
      gpuRef, tolerance);
    EXPECT_TRUE(gpuCpu <= tolerance && gpuRef <= tolerance);
  }
}

NV_TEST(gpu_denoised_path_tracing_converges)
{
  // PT+NEE of the network (In-Shader), 64 x 64: 8 paths per pixel (one per render) denoised reach 35 dB against the
  // GPU's own 2048-path picture, the raw 8-path picture does not; the denoised image comes out in device memory too.
  auto gpu = gpuSession(scene().model, true), rawGpu = gpuSession(scene().model, true);
  RenderRequest q = request(2, 4, 64);
  q.samplesPerPixel = 512;
  RenderResult ref, raw, den;
  for (int k = 0; k < 4; ++k)
    rawGpu->render(q, ref, Memory::Host);
  q.samplesPerPixel = 1;
  q.seed = 2; // another accumulation (the reference's paths are not reused)
  for (int k = 0; k < 8; ++k)
    rawGpu->render(q, raw, Memory::Host);
  q.denoise = true;
  for (int k = 0; k < 8; ++k)
    gpu->render(q, den, Memory::Host);
  const double rawDb = psnr(raw.rgba, ref.rgba), denDb = psnr(den.rgba, ref.rgba);
  std::printf("    8 paths: raw %.2f dB, denoised %.2f dB against 2048 (denoise %.3f ms, guide %.3f ms)\n", rawDb,
    denDb, den.stats.denoiseMilliseconds, den.stats.guideMilliseconds);
  EXPECT_TRUE(ref.stats.accumulatedPaths == 2048 && den.stats.accumulatedPaths == 8 && den.stats.denoised);
  EXPECT_TRUE(denDb >= 35.0 && rawDb < 35.0);
  RenderResult dev;
  gpu->render(q, dev, Memory::Device);
  std::vector<float> copy(den.rgba.size());
  gpu::copyToHost(dev.deviceRgba, copy.size(), copy.data(), dev.deviceReady);
  EXPECT_TRUE(dev.stats.denoised && dev.stats.accumulatedPaths == 9 && allFinite(copy));
}

NV_TEST(gpu_live_network_keeps_its_field_while_the_view_turns)
{
  // RenderRequest::liveRefreshMilliseconds on the GPU: a newer version's interactive render keeps the older grid /
  // ranges (stats.olderField), never passes for the version's picture, and a still render equals a fresh session's.
  Model newer = scene().model;
  for (float& w : newer.params())
    w *= 1.25f;
  for (int path = 0; path < 3; ++path)
  {
    auto gpu = gpuSession(scene().model, true);
    RenderRequest q = request(path, 0, 32);
    RenderResult first, kept, fresh, reference;
    gpu->render(q, first, Memory::Host);
    RenderRequest live = q;
    live.liveRefreshMilliseconds = 1e7;
    gpu->setModel(newer);
    gpu->render(live, kept, Memory::Host);
    EXPECT_TRUE(kept.stats.olderField && !first.stats.olderField);
    if (path == 0)
      EXPECT_TRUE(kept.rgba == first.rgba);
    else
      EXPECT_TRUE(kept.rgba != first.rgba);
    gpu->render(q, fresh, Memory::Host);
    auto other = gpuSession(newer, true);
    other->render(q, reference, Memory::Host);
    EXPECT_TRUE(!fresh.stats.olderField && !fresh.stats.reused);
    const double db = psnr(fresh.rgba, reference.rgba);
    std::printf("    %s: still render after the kept field vs a fresh session %.1f dB\n", kPath[path], db);
    EXPECT_TRUE(db >= 80.0 && fresh.rgba != first.rgba);
  }
}

NV_TEST(gpu_deferred_device_render)
{
  // RenderRequest::deferDeviceSync: a render to device memory returns before its GPU work ends; deviceReady marks the
  // image complete, and the GPU figures arrive with the next render. The image equals the synchronous one, for every
  // path, also while a trainer publishes new networks between renders.
  for (int path = 0; path < 3; ++path)
  {
    auto gpu = gpuSession(scene().model, true);
    RenderRequest q = request(path, 1, 64);
    RenderResult sync, deferred, next;
    gpu->render(q, sync, Memory::Host);
    const double light = q.lightDirection[0];
    q.deferDeviceSync = true;
    q.lightDirection[0] = light - 0.3; // a new picture (not the cached one)
    RenderResult hostRef;
    gpu->render(q, hostRef, Memory::Host); // deferDeviceSync is ignored by a host render
    EXPECT_TRUE(!hostRef.stats.gpuFiguresOfPreviousRender && hostRef.deviceReady == nullptr);
    q.lightDirection[0] = light; // sync's picture again, rendered anew (the cached image is hostRef's)
    gpu->render(q, deferred, Memory::Device);
    EXPECT_TRUE(deferred.stats.gpuFiguresOfPreviousRender && deferred.deviceReady != nullptr);
    std::vector<float> image(size_t(64) * 64 * 4);
    gpu::copyToHost(deferred.deviceRgba, image.size(), image.data(), deferred.deviceReady);
    const double db = psnr(image, sync.rgba);
    std::printf("    %s: deferred device render vs synchronous %.1f dB\n", kPath[path], db);
    EXPECT_TRUE(image == sync.rgba || db >= 80.0);
    // A deferred render reports the previous render's figures; its own come with the next one.
    EXPECT_TRUE(deferred.stats.samplesEvaluated == hostRef.stats.samplesEvaluated);
    q.lightDirection[0] = light + 0.3;
    gpu->render(q, next, Memory::Device);
    EXPECT_TRUE(next.stats.samplesEvaluated == sync.stats.samplesEvaluated && sync.stats.samplesEvaluated > 0);
  }
  // Deferred renders interleaved with publishes: every picture is one network's, whole.
  Model newer = scene().model;
  for (float& w : newer.params())
    w *= 1.25f;
  auto gpu = gpuSession(scene().model, true);
  auto reference = gpuSession(newer, true);
  RenderRequest q = request(2, 0, 64);
  RenderResult ref;
  reference->render(q, ref, Memory::Host);
  q.deferDeviceSync = true;
  for (int round = 0; round < 3; ++round)
  {
    RenderResult r;
    gpu->setModel(round % 2 ? scene().model : newer);
    gpu->render(q, r, Memory::Device);
    if (round == 2)
    {
      std::vector<float> image(size_t(64) * 64 * 4);
      gpu::copyToHost(r.deviceRgba, image.size(), image.data(), r.deviceReady);
      EXPECT_TRUE(image == ref.rgba || psnr(image, ref.rgba) >= 80.0);
    }
  }
}

NV_TEST(gpu_depth_buffer_and_inside_camera)
{
  auto gpu = gpuSession(scene().model, true);
  for (int p = 0; p < 3; ++p)
  {
    // Opaque geometry in front of the volume over the left half of the image: those pixels stay transparent, the
    // right half is unchanged.
    RenderRequest q = request(p, 0, 48);
    RenderResult full, cut, oracleCut;
    gpu->render(q, full, Memory::Host);
    std::vector<float> depth(size_t(48) * 48, 1.0f);
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 24; ++x)
        depth[size_t(y) * 48 + x] = 0.0f; // on the near plane
    q.depth = depth.data();
    gpu->render(q, cut, Memory::Host);
    oracle(p).render(scene().model, 1, q, oracleCut);
    double leftAlpha = 0.0, rightDiff = 0.0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x)
      {
        const size_t i = (size_t(y) * 48 + x) * 4;
        if (x < 24)
          leftAlpha = std::max(leftAlpha, double(cut.rgba[i + 3]));
        else
          for (int k = 0; k < 4; ++k)
            rightDiff = std::max(rightDiff, double(std::fabs(cut.rgba[i + k] - full.rgba[i + k])));
      }
    const double db = psnr(cut.rgba, oracleCut.rgba);
    std::printf("    %-9s occluded half: max alpha %.3g; other half max change %.3g; vs CPU %.1f dB\n", kPath[p],
      leftAlpha, rightDiff, db);
    EXPECT_TRUE(leftAlpha == 0.0 && rightDiff == 0.0 && db >= 38.0);
  }
  // A camera inside the volume sees it from the near plane on.
  RenderRequest q = request(2, 0, 32);
  const Mat4 vp = mul(perspective(70.0, 1.0, 0.01, 10.0), lookAt(std::array<double, 3>{ 0.1, 0.05, 0.2 }.data(),
    std::array<double, 3>{ 0.3, -0.2, -1.0 }.data(), std::array<double, 3>{ 0, 1, 0 }.data()));
  setCamera(q, vp);
  RenderResult in, inCpu;
  gpu->render(q, in, Memory::Host);
  oracle(2).render(scene().model, 1, q, inCpu);
  const double alpha = meanChannel(in.rgba, 3), db = psnr(in.rgba, inCpu.rgba);
  std::printf("    camera inside: mean alpha %.3f, vs CPU %.1f dB\n", alpha, db);
  EXPECT_TRUE(alpha > 0.05 && db >= 38.0);
}

NV_TEST(gpu_real_volume_network_versus_original)
{
  // stent trained to the reference accuracy (37.9 dB, the PyTorch reference at 2000 steps), the anchor's view and
  // transfer function: ray marching of the network (each path) vs the same marcher on the original data.
  const std::string path = dataDir() + "/stent/stent_128x128x256_int16.nhdr";
  if (dataDir().empty() || !std::ifstream(path))
  {
    std::printf("    SKIP: no stent data (%s)\n", path.c_str());
    return;
  }
  nvbench::RawVolume raw = nvbench::loadNhdr(path);
  Model m = nvbench::modelFor(raw, 14, 1);
  SessionOptions so;
  so.kernels = kernels();
  auto s = NetworkSession::create(Device::Cuda, m, so);
  TrainConfig tc;
  auto t = s->createTrainer(raw.view, tc);
  t->steps(2250, nullptr);
  t->publish();
  const double psnrField = compareToSource(*s, raw.view).psnr;
  RenderRequest q;
  q.width = 480;
  q.height = 270;
  nvbench::anchorCamera(raw.view.dims, q.width, q.height, 3, q.viewProjection);
  nvbench::voxelWorldToUnit(raw.view.dims, q.worldToUnit);
  q.transfer = nvbench::anchorTransfer(raw.view.valueMin, raw.view.valueMax);
  q.sampleDistance = 1.0;
  RenderRequest ref = q;
  ref.path = RenderPath::Decode;
  ref.grid = &raw.view;
  RenderResult original;
  s->render(ref, original, Memory::Host);
  for (int p = 0; p < 3; ++p)
  {
    q.path = RenderPath(p);
    RenderResult net;
    s->render(q, net, Memory::Host);
    const double db = psnr(net.rgba, original.rgba);
    std::printf("    stent (field %.2f dB): %s of the network vs the original %.1f dB\n", psnrField, kPath[p], db);
    EXPECT_TRUE(psnrField > 37.5 && db >= 30.0);
  }
}

int main(int argc, char** argv)
{
  kernels() = nvbench::parseKernelFlags(argc, argv);
  int out = 1;
  for (int i = 1; i < argc; ++i)
  {
    if (std::string(argv[i]) == "--data" && i + 1 < argc)
      dataDir() = argv[++i];
    else
      argv[out++] = argv[i];
  }
  argc = out;
  std::string why;
  if (!gpu::deviceUsable(&why))
  {
    std::printf("SKIPPED: no usable GPU (%s)\n", why.c_str());
    return kSkip;
  }
  std::printf("GPU: %s\n", gpu::deviceDescription().c_str());
  return nvtest::runCases(argc, argv);
}
