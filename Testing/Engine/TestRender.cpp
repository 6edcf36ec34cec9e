// The CPU renderer: every path x shading mode against committed baselines, the paths against each other, their
// statistics, caching, empty-space skipping, progressive decoding, path-tracing convergence and a real volume.
//   nvTestRender [case] --baseline DIR [--data DIR] [--generate]
#include "Core/Error.h"
#include "Core/Macrocells.h"
#include "Core/NetworkSession.h"
#include "Cpu/CpuInference.h"
#include "Cpu/CpuHalfNetwork.h"
#include "Nhdr.h"
#include "Reference.h"
#include "RenderFixtures.h"
#include "TestHarness.h"

#include <chrono>
#include <map>
#include <thread>

using namespace nv;
using namespace nvtest;

namespace
{
struct Options
{
  std::string baseline, data;
  bool generate = false;
};
Options& options()
{
  static Options o;
  return o;
}

ThreadPool& pool()
{
  static ThreadPool p(2);
  return p;
}

constexpr int kGrid = 40;

/// The blob field on a 40^3 grid and a small model trained on it (300 steps, one thread, fixed seed).
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

const char* pathTag(int p)
{
  static const char* t[] = { "decode", "streaming", "inshader" };
  return t[p];
}
const char* modeTag(int m)
{
  static const char* t[] = { "rm", "rmgrad", "rmshadow", "pt", "ptnee" };
  return t[m];
}

/// One renderer per path (their caches persist across the cases), and the baseline images of the first case.
CpuRenderer& renderer(int path)
{
  static std::unique_ptr<CpuRenderer> r[3];
  if (!r[path])
    r[path] = std::make_unique<CpuRenderer>(pool());
  return *r[path];
}
std::map<std::pair<int, int>, RenderResult>& images()
{
  static std::map<std::pair<int, int>, RenderResult> m;
  return m;
}
const RenderResult& image(int path, int mode)
{
  auto& m = images();
  auto it = m.find({ path, mode });
  if (it != m.end())
    return it->second;
  RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode(mode));
  RenderResult& res = m[{ path, mode }];
  renderer(path).render(scene().model, 1, q, res);
  return res;
}
} // namespace

NV_TEST(every_path_and_mode_matches_its_baseline)
{
  for (int mode = 0; mode < 5; ++mode)
    for (int path = 0; path < 3; ++path)
    {
      const RenderResult& res = image(path, mode);
      const RenderStats& s = res.stats;
      const std::string name = std::string("render_") + pathTag(path) + "_" + modeTag(mode) + ".ppm";
      const auto rgb = toRgb8(res.rgba, 64, 64);
      std::printf("  %-26s %7.1f ms  rays %6lld  evaluated %8lld  plain %8lld  wavefronts %4lld  alpha %.3f\n",
        name.c_str(), s.renderMilliseconds, (long long)s.rays, (long long)s.samplesEvaluated,
        (long long)s.samplesPlain, (long long)s.wavefronts, meanChannel(res.rgba, 3));
      EXPECT_TRUE(allFinite(res.rgba));
      EXPECT_TRUE(meanChannel(res.rgba, 3) > 0.1); // the volume is in the picture
      const std::string file = options().baseline + "/" + name;
      if (options().generate)
      {
        EXPECT_TRUE(writePpm(file, rgb, 64, 64));
        continue;
      }
      std::vector<unsigned char> base;
      int w = 0, h = 0;
      if (!readPpm(file, base, w, h) || w != 64 || h != 64)
      {
        fail(__FILE__, __LINE__, "missing baseline " + file + " (run with --generate)");
        continue;
      }
      const double p = psnr8(rgb, base);
      if (!(p >= 40.0))
      {
        writePpm(name, rgb, 64, 64); // next to the test's working directory, for inspection
        fail(__FILE__, __LINE__, name + ": PSNR " + std::to_string(p) + " dB against the baseline (< 40)");
      }
    }
}

NV_TEST(paths_agree_but_are_not_identical)
{
  // Ray marching is deterministic: the three paths differ only by their field evaluation (trilinear of the decoded
  // grid, fp16 in-shader network, fp32 batched network). Path tracing differs by noise as well: the paths share
  // their random streams, but each has its own majorants (exact for the grid, probe-widened for the network), so
  // the decisions decorrelate. Measured noise floor at 32x32, 30-degree sun, 256 spp: the same path with two seeds
  // is 24 dB apart (PT) and 40 dB (PT+NEE). So path tracing is compared on converged images: 24x24, 512 spp (PT)
  // and 128 spp (PT+NEE).
  for (int mode = 0; mode < 3; ++mode)
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b)
      {
        const auto& x = image(a, mode).rgba;
        const auto& y = image(b, mode).rgba;
        const double p = psnr(x, y);
        std::printf("  %-9s %-9s vs %-9s %6.2f dB\n", modeTag(mode), pathTag(a), pathTag(b), p);
        EXPECT_TRUE(p >= 30.0);
        EXPECT_TRUE(x != y);
      }
  for (int mode = 3; mode < 5; ++mode)
  {
    std::vector<float> img[3];
    for (int path = 0; path < 3; ++path)
    {
      CpuRenderer r(pool());
      RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode(mode), 24, 24);
      q.samplesPerPixel = mode == 3 ? 512 : 128;
      RenderResult res;
      r.render(scene().model, 1, q, res);
      img[path] = res.rgba;
    }
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b)
      {
        const double p = psnr(img[a], img[b]);
        std::printf("  %-9s %-9s vs %-9s %6.2f dB (24x24, %d spp)\n", modeTag(mode), pathTag(a), pathTag(b), p,
          mode == 3 ? 512 : 128);
        EXPECT_TRUE(p >= 30.0);
        EXPECT_TRUE(img[a] != img[b]);
      }
  }
}

NV_TEST(statistics_show_each_path_ran_its_own_code)
{
  for (int mode = 0; mode < 5; ++mode)
  {
    const RenderStats& d = image(0, mode).stats;
    const RenderStats& s = image(1, mode).stats;
    const RenderStats& i = image(2, mode).stats;
    EXPECT_TRUE(d.path == RenderPath::Decode && s.path == RenderPath::SampleStreaming);
    EXPECT_TRUE(i.path == RenderPath::InShader);
    EXPECT_TRUE(d.wavefronts == 0 && i.wavefronts == 0 && s.wavefronts > 0);
    const int64_t rays = mode >= 3 ? 64 * 64 * 16 : 64 * 64;
    EXPECT_TRUE(d.rays == rays && s.rays == rays && i.rays == rays);
    EXPECT_TRUE(d.samplesEvaluated > 0 && s.samplesEvaluated > 0 && i.samplesEvaluated > 0);
    if (mode < 3)
    {
      // Ray marching: one evaluation per step (seven with gradients), fewer than a plain marcher's thanks to
      // skipping and termination. Streaming advances K steps at once: it overshoots termination and shadows.
      EXPECT_TRUE(d.samplesPlain > 0 && i.samplesPlain > 0 && s.samplesPlain > 0);
      EXPECT_TRUE(i.samplesEvaluated <= (mode == 1 ? 7 : 1) * i.samplesPlain * (mode == 2 ? 40 : 1));
      EXPECT_TRUE(s.samplesEvaluated >= i.samplesEvaluated);
      // Waves: at least the longest ray's steps / K.
      EXPECT_TRUE(s.wavefronts >= 2);
    }
    else
    {
      EXPECT_TRUE(d.samplesPlain == 0 && d.accumulatedFrames == 1 && s.accumulatedFrames == 1);
    }
    EXPECT_TRUE(!d.decodePending && !d.reused);
  }
}

NV_TEST(session_renders_through_the_cpu_renderer)
{
  // NetworkSession::create(Cpu) renders with the same renderer: the same pictures, its version keys the caches
  // (a publish by a trainer restarts them).
  auto s = NetworkSession::create(Device::Cpu, scene().model);
  for (int path = 0; path < 3; ++path)
  {
    RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode::RayMarch);
    RenderResult a, b;
    s->render(q, a);
    EXPECT_TRUE(a.rgba == image(path, 0).rgba && a.stats.path == RenderPath(path));
    s->render(q, b);
    EXPECT_TRUE(b.stats.reused);
  }
  const uint64_t v = s->version();
  auto tr = s->createTrainer(scene().volume, TrainConfig());
  tr->step();
  tr->publish();
  EXPECT_TRUE(s->version() != v);
  RenderRequest q = blobRequest(scene().model, RenderPath::InShader, ShadingMode::RayMarch);
  RenderResult c;
  s->render(q, c);
  EXPECT_TRUE(!c.stats.reused && c.rgba != image(2, 0).rgba);
}

NV_TEST(in_shader_numerics_are_the_gpus_fp16)
{
  // The In-Shader evaluator against a double-precision evaluation with the same fp16 roundings (written here from
  // the description): equal up to accumulation order; and different from the fp32 network used by streaming.
  const Model& m = scene().model;
  CpuHalfTable table;
  table.update(m, 1);
  EXPECT_TRUE(table.table() != m.params().data()); // fp32-trained: a rounded copy
  const CpuHalfNetwork half(m, table.table());
  const CpuInference full(m);
  const int n = 2000;
  std::vector<float> xyz(3 * n), a(n), b(n);
  for (int i = 0; i < n; ++i)
    randomPoint(99, 0, i, &xyz[3 * i]);
  half.evaluate(xyz.data(), n, a.data());
  full.inferPoints(pool(), xyz.data(), n, b.data());
  auto h = [](double v) { return double(halfToFloat(floatToHalf(float(v)))); };
  const auto levels = refLevels(m.config().encoding);
  const int F = m.config().encoding.featuresPerLevel, H = m.config().network.hiddenLayers;
  double worstRef = 0, worstFp32 = 0;
  for (int i = 0; i < n; ++i)
  {
    const double x[3] = { xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2] };
    // encoding from fp16 table entries, rounded to fp16 per feature
    std::vector<double> act(levels.size() * F, 0.0);
    for (size_t l = 0; l < levels.size(); ++l)
    {
      double p[3], f[3];
      uint64_t c[3];
      for (int d = 0; d < 3; ++d)
      {
        p[d] = double(float(x[d]) * float(levels[l].scale) + 0.5f);
        c[d] = uint64_t(std::floor(p[d]));
        f[d] = p[d] - std::floor(p[d]);
      }
      for (int k = 0; k < 8; ++k)
      {
        const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
        const double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
        const uint64_t idx = refIndex(levels[l], c[0] + dx, c[1] + dy, c[2] + dz);
        for (int j = 0; j < F; ++j)
          act[l * F + j] += w * h(m.params()[idx * F + j]);
      }
    }
    for (double& v : act)
      v = h(v);
    for (int l = 0; l <= H; ++l)
    {
      const int in = m.layerInputs(l), out = m.layerOutputs(l);
      const float* W = m.params().data() + m.layerOffset(l);
      std::vector<double> y(out, 0.0);
      for (int o = 0; o < out; ++o)
      {
        for (int k = 0; k < in; ++k)
          y[o] += (l < H ? h(W[size_t(o) * in + k]) : double(W[size_t(o) * in + k])) * act[k];
        if (l < H)
          y[o] = h(y[o] > 0 ? y[o] : 0);
      }
      act.swap(y);
    }
    worstRef = std::max(worstRef, std::fabs(act[0] - a[i]));
    worstFp32 = std::max(worstFp32, double(std::fabs(a[i] - b[i])));
  }
  std::printf("  in-shader vs fp16 reference: max %.2e; vs fp32 network: max %.2e\n", worstRef, worstFp32);
  EXPECT_TRUE(worstRef < 2e-3);
  EXPECT_TRUE(worstFp32 > 1e-4 && worstFp32 < 2e-2);
}

NV_TEST(identical_request_returns_the_cached_image)
{
  for (int path = 0; path < 3; ++path)
  {
    CpuRenderer r(pool());
    RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode::RayMarch, 32, 32);
    RenderResult a, b, c;
    r.render(scene().model, 1, q, a);
    r.render(scene().model, 1, q, b);
    EXPECT_TRUE(!a.stats.reused && b.stats.reused && a.rgba == b.rgba);
    EXPECT_TRUE(b.stats.samplesEvaluated == a.stats.samplesEvaluated);
    q.transfer.rgba[4 * 40 + 3] = 0.9f; // the transfer function changes: trace again
    r.render(scene().model, 1, q, c);
    EXPECT_TRUE(!c.stats.reused && c.rgba != a.rgba);
    r.render(scene().model, 2, q, c); // so does a new network version
    EXPECT_TRUE(!c.stats.reused);
  }
}

NV_TEST(macrocells_recompute_only_what_changed)
{
  // Ranges follow the field (network version, decoded grid), majorants the transfer function; a camera move
  // recomputes neither.
  for (int path = 0; path < 3; ++path)
  {
    CpuRenderer r(pool());
    const CpuMacrocells& c = r.macrocells();
    RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode::RayMarch, 16, 16);
    RenderResult res;
    r.render(scene().model, 1, q, res);
    EXPECT_TRUE(c.rangeUpdates() == 1 && c.majorantUpdates() == 1);
    EXPECT_TRUE(res.stats.decodeMilliseconds > 0.0);
    q.viewProjection[3] += 0.1;
    r.render(scene().model, 1, q, res);
    EXPECT_TRUE(c.rangeUpdates() == 1 && c.majorantUpdates() == 1 && !res.stats.reused);
    q.transfer.rgba[4 * 20 + 3] = 0.0f;
    r.render(scene().model, 1, q, res);
    EXPECT_TRUE(c.rangeUpdates() == 1 && c.majorantUpdates() == 2);
    r.render(scene().model, 2, q, res);
    EXPECT_TRUE(c.rangeUpdates() == 2 && c.majorantUpdates() == 3);
  }
}

NV_TEST(a_live_network_keeps_its_field_while_the_view_turns)
{
  // RenderRequest::liveRefreshMilliseconds: an interactive render of a newer network version keeps the decoded grid
  // (Decode) or the lattice behind the macrocell ranges (network paths) of the older version until it is that old;
  // 0 derives them for every version. The field kept is reported (stats.olderField) and never passes for the
  // version's own picture.
  Model newer = scene().model;
  for (float& w : newer.params())
    w *= 1.25f; // another network: a visibly different picture
  for (int path = 0; path < 3; ++path)
  {
    CpuRenderer r(pool());
    const CpuMacrocells& c = r.macrocells();
    RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode::RayMarch, 24, 24);
    RenderResult first, kept, fresh, reference;
    r.render(scene().model, 1, q, first);
    EXPECT_TRUE(!first.stats.olderField && c.rangeUpdates() == 1);

    RenderRequest live = q;
    live.liveRefreshMilliseconds = 1e7;
    r.render(newer, 2, live, kept);
    EXPECT_TRUE(kept.stats.olderField && c.rangeUpdates() == 1);
    if (path == 0)
      EXPECT_TRUE(kept.rgba == first.rgba); // the same grid marched again: the older picture
    else
      EXPECT_TRUE(kept.rgba != first.rgba); // the newer network, inside the older ranges

    r.render(newer, 2, q, fresh); // a still render: the current version's field
    CpuRenderer other(pool());
    other.render(newer, 2, q, reference);
    EXPECT_TRUE(!fresh.stats.olderField && !fresh.stats.reused && c.rangeUpdates() == 2);
    EXPECT_TRUE(fresh.rgba == reference.rgba && fresh.rgba != first.rgba);

    live.liveRefreshMilliseconds = 1.0; // too old after 20 ms: derived again
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    r.render(scene().model, 3, live, kept);
    EXPECT_TRUE(!kept.stats.olderField && c.rangeUpdates() == 3);
  }
  RenderRequest bad = blobRequest(scene().model, RenderPath::Decode, ShadingMode::RayMarch, 8, 8);
  for (double ms : { -1.0, std::nan(""), HUGE_VAL })
  {
    bad.liveRefreshMilliseconds = ms;
    CpuRenderer r(pool());
    RenderResult res;
    EXPECT_THROW_MSG(r.render(scene().model, 1, bad, res), "live refresh interval");
  }
}

NV_TEST(nothing_is_drawn_outside_the_domain)
{
  // A resampled source's domain mask (SourceInfo::domain): here the half x < 0.5 of the box. Looking along -z with
  // an orthographic camera, every ray stays on one side: pixels over the outside half are empty (alpha exactly 0)
  // on every path and shading mode, pixels over the inside half are the picture without a mask, bit for bit.
  Model masked = scene().model;
  keepHalfX(masked);
  const int64_t* n = masked.source.dims;
  const int w = 48, h = 40;
  const Mat4 vp = orthoAlongZ();
  for (int path = 0; path < 3; ++path)
    for (int mode = 0; mode < 2; ++mode)
    {
      CpuRenderer plainR(pool()), maskedR(pool());
      RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode(mode), w, h);
      setCamera(q, vp);
      RenderResult a, b;
      plainR.render(scene().model, 1, q, a);
      maskedR.render(masked, 1, q, b);
      int64_t outsideLit = 0, insideDiffer = 0, insideLit = 0, outsidePixels = 0, outsideLitPlain = 0;
      for (int py = 0; py < h; ++py)
        for (int px = 0; px < w; ++px)
        {
          const double ux = (-1.2 + 2.4 * (px + 0.5) / w + 1.0) / 2.0;
          const size_t k = 4 * (size_t(py) * w + px);
          if (ux > 0.5 + 1.0 / double(n[0] - 1))
          {
            ++outsidePixels;
            outsideLit += b.rgba[k + 3] != 0.0f ? 1 : 0;
            outsideLitPlain += a.rgba[k + 3] > 0.01f ? 1 : 0;
          }
          else if (ux < 0.5 - 2.5 / double(n[0] - 1) && ux > 0.0) // gradient neighbours inside too
          {
            insideLit += a.rgba[k + 3] > 0.01f ? 1 : 0;
            for (int ch = 0; ch < 4; ++ch)
              insideDiffer += a.rgba[k + ch] != b.rgba[k + ch] ? 1 : 0;
          }
        }
      std::printf("  %-9s %-9s outside: %lld of %lld pixels lit; inside: %lld lit, %lld values differ\n", pathTag(path),
        modeTag(mode), (long long)outsideLit, (long long)outsidePixels, (long long)insideLit, (long long)insideDiffer);
      EXPECT_TRUE(outsidePixels > 0 && outsideLit == 0 && outsideLitPlain > 50); // drawn there without the mask
      EXPECT_TRUE(insideLit > 50 && insideDiffer == 0);
    }
}

NV_TEST(empty_cells_of_a_sparse_source_are_its_background)
{
  // A sparse source's occupancy (SourceInfo::occupancy): the macrocells of the half x >= 0.5 hold the background
  // (the field's minimum, transparent here) exactly. Looking along -z with an orthographic camera: on every path the
  // pixels over that half are empty where the plain network draws something, the pixels well inside the occupied
  // half are bit for bit the plain picture, and skipping evaluates fewer samples than without the mask.
  Model sparse = scene().model;
  occupyHalfX(sparse, sparse.source.valueMin);
  const MacrocellLayout cells = macrocellLayout(sparse.source.dims);
  const double firstEmpty = double(cells.dims[0] / 2) / cells.scale[0]; // u of the first empty cell along x
  const int w = 48, h = 40;
  const Mat4 vp = orthoAlongZ();
  for (int path = 0; path < 3; ++path)
  {
    CpuRenderer plainR(pool()), sparseR(pool());
    RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode(0), w, h);
    setCamera(q, vp);
    RenderResult a, b;
    plainR.render(scene().model, 1, q, a);
    sparseR.render(sparse, 1, q, b);
    int64_t emptyLit = 0, emptyLitPlain = 0, insideLit = 0, insideDiffer = 0;
    for (int py = 0; py < h; ++py)
      for (int px = 0; px < w; ++px)
      {
        const double ux = (-1.2 + 2.4 * (px + 0.5) / w + 1.0) / 2.0;
        const size_t k = 4 * (size_t(py) * w + px);
        if (ux > firstEmpty + 0.02 && ux < 1.0)
        {
          emptyLit += b.rgba[k + 3] != 0.0f ? 1 : 0;
          emptyLitPlain += a.rgba[k + 3] > 0.01f ? 1 : 0;
        }
        else if (ux < firstEmpty - 0.05 && ux > 0.0)
        {
          insideLit += a.rgba[k + 3] > 0.01f ? 1 : 0;
          for (int ch = 0; ch < 4; ++ch)
            insideDiffer += a.rgba[k + ch] != b.rgba[k + ch] ? 1 : 0;
        }
      }
    std::printf("  %-9s empty half: %lld pixels lit (plain: %lld); occupied half: %lld lit, %lld values differ; "
                "samples %lld with the mask, %lld without\n", pathTag(path), (long long)emptyLit,
      (long long)emptyLitPlain, (long long)insideLit, (long long)insideDiffer, (long long)b.stats.samplesEvaluated,
      (long long)a.stats.samplesEvaluated);
    EXPECT_TRUE(emptyLitPlain > 50 && emptyLit == 0);
    EXPECT_TRUE(insideLit > 50 && insideDiffer == 0);
    EXPECT_TRUE(b.stats.samplesEvaluated < a.stats.samplesEvaluated);
  }
}

NV_TEST(skipping_does_not_change_the_picture)
{
  // Ray-marching modes of every path with skipping on and off: the macrocell ranges are exact for the decoded grid
  // and, for the network, widened by per-cell network probes (default) or by the GPU's fixed kNetworkRangeMargin
  // (probesPerCell = 0), so the pictures agree and skipping evaluates less.
  CpuRendererOptions gpuLike;
  gpuLike.probesPerCell = 0;
  gpuLike.latticeMax = int(kMaxLatticeSamples);
  CpuRenderer fixedMargin[2] = { CpuRenderer(pool(), gpuLike), CpuRenderer(pool(), gpuLike) };
  for (int variant = 0; variant < 2; ++variant)
    for (int path = variant; path < 3; ++path)
      for (int mode = 0; mode < 3; ++mode)
      {
        CpuRenderer& r = variant == 0 ? renderer(path) : fixedMargin[path - 1];
        RenderRequest q = blobRequest(scene().model, RenderPath(path), ShadingMode(mode), 48, 48);
        RenderResult on, off;
        r.render(scene().model, 1, q, on);
        q.emptySpaceSkipping = false;
        r.render(scene().model, 1, q, off);
        const double p = psnr(on.rgba, off.rgba);
        const double ratio = double(on.stats.samplesEvaluated) / double(off.stats.samplesEvaluated);
        std::printf("  %-9s %-9s %-6s on/off %s dB, samples %lld / %lld = %.3f (empty cells %lld of %lld, widening "
                    "%.4f)\n",
          pathTag(path), modeTag(mode), variant ? "fixed" : "probes",
          std::isinf(p) ? "identical" : std::to_string(p).c_str(),
          (long long)on.stats.samplesEvaluated, (long long)off.stats.samplesEvaluated, ratio,
          (long long)r.macrocells().emptyCells(), (long long)r.macrocells().cellCount(),
          r.macrocells().largestWidening());
        EXPECT_TRUE(p >= 45.0);
        EXPECT_TRUE(ratio < 0.8);
      }
}

NV_TEST(progressive_decode)
{
  // A renderer whose threshold makes the 40^3 grid "large": the first render uses a coarse grid and decodes the
  // full one in the background; a later render shows exactly the synchronous full-grid picture.
  CpuRendererOptions o;
  o.progressiveSamples = 4096;
  CpuRenderer r(pool(), o);
  RenderRequest q = blobRequest(scene().model, RenderPath::Decode, ShadingMode::RayMarch, 32, 32);
  CpuRenderer reference(pool());
  RenderResult full;
  reference.render(scene().model, 1, q, full);
  RenderResult res;
  r.render(scene().model, 1, q, res);
  EXPECT_TRUE(res.stats.decodePending && r.workPending());
  const std::vector<float> coarse = res.rgba;
  const double pc = psnr(coarse, full.rgba);
  int renders = 1;
  const auto start = std::chrono::steady_clock::now();
  while (res.stats.decodePending && std::chrono::steady_clock::now() - start < std::chrono::seconds(60))
  {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    r.render(scene().model, 1, q, res);
    ++renders;
  }
  std::printf("  coarse grid vs full: %.2f dB; full grid after %d renders\n", pc, renders);
  EXPECT_TRUE(!res.stats.decodePending && !r.workPending());
  EXPECT_TRUE(res.rgba == full.rgba);
  EXPECT_TRUE(coarse != full.rgba && pc > 15.0);

  // A new version while decoding: the stale job is dropped and the new network is shown.
  Model other = scene().model;
  for (size_t i = other.layerOffset(other.config().network.hiddenLayers); i < other.paramCount(); ++i)
    other.params()[i] *= 1.2f;
  RenderResult expect;
  reference.render(other, 7, q, expect);
  r.render(scene().model, 3, q, res); // starts a job for version 3
  EXPECT_TRUE(res.stats.decodePending && r.workPending());
  RenderRequest other16 = q;
  other16.path = RenderPath::InShader;
  RenderResult net;
  r.render(scene().model, 3, other16, net); // another path: the job may run on, but asks for no re-render
  EXPECT_TRUE(!r.workPending() && !net.stats.decodePending);
  r.render(other, 7, q, res); // version 7: cancels it
  while (res.stats.decodePending && std::chrono::steady_clock::now() - start < std::chrono::seconds(120))
  {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    r.render(other, 7, q, res);
  }
  EXPECT_TRUE(res.rgba == expect.rgba);

  // A caller that waits for the final picture (waitForDecode): the full grid at once, and a background decode already
  // under way is finished with the caller's threads -- the same picture, bit for bit, as the synchronous decode.
  {
    RenderRequest big = q;
    big.decodeResolution[0] = big.decodeResolution[1] = big.decodeResolution[2] = 120;
    RenderResult expectBig;
    reference.render(scene().model, 11, big, expectBig);
    CpuRenderer helped(pool(), o), direct(pool(), o);
    helped.render(scene().model, 11, big, res); // coarse; the full grid decodes in the background
    EXPECT_TRUE(res.stats.decodePending && helped.workPending());
    big.waitForDecode = true;
    helped.render(scene().model, 11, big, res);
    EXPECT_TRUE(!res.stats.decodePending && !helped.workPending());
    EXPECT_TRUE(res.rgba == expectBig.rgba);
    direct.render(scene().model, 11, big, res); // no job: decoded now, never a coarse grid
    EXPECT_TRUE(!res.stats.decodePending && !direct.workPending());
    EXPECT_TRUE(res.rgba == expectBig.rgba);
  }

  // Destroyed in the middle of a (large) background decode: cancelled and joined promptly.
  const auto t0 = std::chrono::steady_clock::now();
  {
    CpuRenderer big(pool(), o);
    q.decodeResolution[0] = q.decodeResolution[1] = q.decodeResolution[2] = 400;
    big.render(scene().model, 1, q, res);
    EXPECT_TRUE(res.stats.decodePending && big.workPending());
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("  render + destroy during a 400^3 background decode: %.0f ms\n", ms);
  EXPECT_TRUE(ms < 5000);
}

NV_TEST(path_tracing_with_and_without_nee_converge)
{
  // Same estimand, different estimators. Accumulating 4 frames of 512 spp: the PT image approaches the PT+NEE one
  // as noise does (about +6 dB per 4x spp; a bias would stall it). Measured: 24x24, sun lobe of 30 degrees (half
  // maximum), 2048 spp: 41.5 dB and mean red within 0.2% (34.6 dB at 512 spp). TestPathTracingConvergence checks the
  // same at 64 x 64 with the default light.
  const Model& m = scene().model;
  CpuRenderer r[2] = { CpuRenderer(pool()), CpuRenderer(pool()) };
  RenderRequest q[2];
  RenderResult res[2];
  double first = 0.0;
  for (int frame = 0; frame < 4; ++frame)
  {
    for (int k = 0; k < 2; ++k)
    {
      q[k] = blobRequest(m, RenderPath::Decode, k ? ShadingMode::PathTraceNee : ShadingMode::PathTrace, 24, 24);
      q[k].samplesPerPixel = 512;
      r[k].render(m, 1, q[k], res[k]);
      EXPECT_TRUE(res[k].stats.accumulatedFrames == frame + 1);
    }
    if (frame == 0)
      first = psnr(res[0].rgba, res[1].rgba);
  }
  const double p = psnr(res[0].rgba, res[1].rgba);
  std::printf("  PT vs PT+NEE: %.2f dB at 512 spp, %.2f dB at 2048 spp; mean red %.4f vs %.4f\n", first, p,
    meanChannel(res[0].rgba, 0), meanChannel(res[1].rgba, 0));
  EXPECT_TRUE(p >= 34.0);
  EXPECT_TRUE(p >= first + 4.0);
  EXPECT_NEAR_REL(meanChannel(res[0].rgba, 0), meanChannel(res[1].rgba, 0), 0.015, 0.0);
}

NV_TEST(real_volume_network_versus_original)
{
  const std::string file = options().data + "/nucleon/nucleon_41x41x41_uint8.nhdr";
  if (options().data.empty() || !std::ifstream(file))
  {
    std::printf("  SKIP: %s not found\n", file.c_str());
    return;
  }
  const nvbench::RawVolume raw = nvbench::loadNhdr(file);
  ModelConfig c;
  c.encoding.levels = 12;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = 15;
  c.encoding.baseResolution = 4;
  c.encoding.finestResolution = 82;
  c.network.width = 32;
  c.network.hiddenLayers = 2;
  const auto t0 = std::chrono::steady_clock::now();
  const Model m = trainModel(raw.view, c, 1500, 8192, 1, 2);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const ErrorStats e = nvtest::compareToSource(m, raw.view, Device::Cpu, 2);
  std::printf("  nucleon 41^3: trained in %.1f s, PSNR %.2f dB\n", secs, e.psnr);
  EXPECT_TRUE(e.psnr > 35.0);
  RenderRequest q = blobRequest(m, RenderPath::Decode, ShadingMode::RayMarch, 64, 64);
  q.transfer = blobTransfer(raw.view.valueMin, raw.view.valueMax, 0.6f);
  RenderResult original;
  q.grid = &raw.view;
  renderer(0).render(m, 11, q, original);
  EXPECT_TRUE(meanChannel(original.rgba, 3) > 0.05);
  for (int path = 0; path < 3; ++path)
  {
    q.path = RenderPath(path);
    q.grid = nullptr;
    RenderResult res;
    renderer(path).render(m, 11, q, res);
    const double p = psnr(res.rgba, original.rgba);
    std::printf("  ray marching, %s of the network vs the original (trilinear): %.2f dB\n", pathTag(path), p);
    EXPECT_TRUE(p >= 30.0);
  }
}

int main(int argc, char** argv)
{
  std::vector<char*> rest = { argv[0] };
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (a == "--generate")
      options().generate = true;
    else if (a == "--baseline" && i + 1 < argc)
      options().baseline = argv[++i];
    else if (a == "--data" && i + 1 < argc)
      options().data = argv[++i];
    else
      rest.push_back(argv[i]);
  }
  if (options().baseline.empty())
  {
    std::printf("usage: nvTestRender [case] --baseline DIR [--data DIR] [--generate]\n");
    return 2;
  }
  return nvtest::runCases(int(rest.size()), rest.data());
}
