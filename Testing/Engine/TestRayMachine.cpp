// The shared ray machine (Core/RayMachine.h, RenderSetup, Macrocells) run by the CPU renderer, against analytic
// answers: slab transmittance, delta tracking's collision probability, empty space, early termination, cameras,
// depth compositing, NaN holes, path-tracing accumulation, invalid requests.
#include "Core/Error.h"
#include "Cpu/CpuHalfNetwork.h"
#include "RenderFixtures.h"
#include "TestHarness.h"

#include <limits>

using namespace nv;
using namespace nvtest;

namespace
{
constexpr int kN = 33; // slab grid: 33^3 samples over [-1,1]^3 (spacing 1/16), 4 x 4 x 4 macrocells

/// An untrained model whose source is an n^3 grid with values in [0,1] (the Decode path renders request.grid).
Model gridModel(int n)
{
  Model m(smallRenderConfig());
  m.initialize(1);
  for (int a = 0; a < 3; ++a)
    m.source.dims[a] = n;
  m.source.valueMin = 0.0;
  m.source.valueMax = 1.0;
  return m;
}

/// Constant 0.5, except a block of 1.0 in the corner x, y <= -0.9375 (all z): denser than the slab, in the corner
/// macrocells only, away from the tested rays, so that the global majorant exceeds the slab's extinction (null
/// collisions without skipping) while the tested rays' cells have the slab's extinction as majorant.
std::vector<float> slabGrid()
{
  std::vector<float> v(kN * kN * kN, 0.5f);
  for (int z = 0; z < kN; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x)
        v[(z * kN + y) * kN + x] = 1.0f;
  return v;
}

/// Two entries over [0,1]: opacity 0.1 at 0 and 0.6 at 1 per unit distance 0.5; extinction is linear in between.
TransferFunction slabTransfer(float a0 = 0.1f, float a1 = 0.6f)
{
  TransferFunction tf;
  tf.rgba = { 1.0f, 0.5f, 0.25f, a0, 0.2f, 0.6f, 1.0f, a1 };
  tf.valueMin = 0.0;
  tf.valueMax = 1.0;
  tf.unitDistance = 0.5;
  return tf;
}
double slabSigma(float a0 = 0.1f, float a1 = 0.6f)
{
  return 0.5 * (-std::log(1.0 - a0) / 0.5 - std::log(1.0 - a1) / 0.5);
}

/// Orthographic view down -z from z = 3 of the square [-1.5, 1.5]^2: pixel centres with |x|, |y| < 1 see a chord of 2.
Mat4 orthoDown()
{
  const double eye[3] = { 0, 0, 3 }, c[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
  return mul(ortho(-1.5, 1.5, -1.5, 1.5, 0.5, 10.0), lookAt(eye, c, up));
}
double pixelCoord(int p, int n)
{
  return -1.5 + 3.0 * (p + 0.5) / n;
}

RenderRequest slabRequest(const VolumeView& grid, int w = 32, int h = 32)
{
  RenderRequest q;
  q.width = w;
  q.height = h;
  setCamera(q, orthoDown());
  unitBox(q.worldToUnit);
  q.transfer = slabTransfer();
  q.path = RenderPath::Decode;
  q.shading = ShadingMode::RayMarch;
  q.sampleDistance = 2.0 / 64.0;
  q.terminationOpacity = 1.0; // off
  q.grid = &grid;
  return q;
}

/// Pixels whose rays cross the slab only (clear of the corner block and its interpolation footprint).
bool slabPixel(int px, int py, int w, int h)
{
  const double x = pixelCoord(px, w), y = pixelCoord(py, h);
  return x > -0.4 && x < 0.95 && y > -0.4 && y < 0.95;
}

ThreadPool& pool()
{
  static ThreadPool p(2);
  return p;
}
} // namespace

NV_TEST(half_rounding_matches_the_reference_conversion)
{
  // Edge cases and 2^20 pseudo-random bit patterns: both fp16 roundings equal floatToHalf -> halfToFloat.
  std::vector<float> xs = { 0.0f, -0.0f, 1.0f, 65504.0f, 65519.99f, 65520.0f, 1e-8f, 2.9802322e-8f, 5.96e-8f,
    6.1035156e-5f, 6.10351e-5f, 1.0009765625f, 1.00048828125f, 1.00146484375f, -3.3e-7f,
    std::numeric_limits<float>::infinity() };
  for (uint64_t i = 0; i < (1u << 20); ++i)
  {
    const uint32_t bits = uint32_t(mix64(i) >> 32);
    float f;
    std::memcpy(&f, &bits, 4);
    xs.push_back(f);
  }
  int bad = 0, badPortable = 0;
  for (float x : xs)
  {
    const float ref = halfToFloat(floatToHalf(x));
    auto same = [&](float y) { return (std::isnan(ref) && std::isnan(y)) || std::memcmp(&ref, &y, 4) == 0; };
    bad += same(roundHalf(x)) ? 0 : 1;
    badPortable += same(roundHalfPortable(x)) ? 0 : 1;
  }
  EXPECT_TRUE(bad == 0);
  EXPECT_TRUE(badPortable == 0);
}

NV_TEST(slab_transmittance_ray_marching)
{
  const auto data = slabGrid();
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  RenderRequest q = slabRequest(grid);
  const double sigma = slabSigma(), expect = 1.0 - std::exp(-sigma * 2.0);
  for (int skip = 0; skip < 2; ++skip)
  {
    q.emptySpaceSkipping = skip != 0;
    RenderResult res;
    r.render(m, 1, q, res);
    double worst = 0, worstColour = 0;
    int outside = 0, checked = 0;
    for (int py = 0; py < q.height; ++py)
      for (int px = 0; px < q.width; ++px)
      {
        const float* p = &res.rgba[4 * (py * q.width + px)];
        const double x = pixelCoord(px, q.width), y = pixelCoord(py, q.height);
        if (std::fabs(x) > 1 || std::fabs(y) > 1)
        {
          outside += p[0] == 0 && p[1] == 0 && p[2] == 0 && p[3] == 0 ? 0 : 1;
          continue;
        }
        if (!slabPixel(px, py, q.width, q.height))
          continue;
        ++checked;
        worst = std::max(worst, std::fabs(p[3] - expect));
        // colour: the interpolated entry colour at 0.5 times alpha (premultiplied)
        const double rgb[3] = { 0.6, 0.55, 0.625 };
        for (int c = 0; c < 3; ++c)
          worstColour = std::max(worstColour, std::fabs(p[c] - rgb[c] * p[3]));
      }
    std::printf("  skipping %d: alpha %.6f expected %.6f (worst |diff| %.2e over %d pixels), colour %.2e\n", skip,
      res.rgba[4 * (16 * q.width + 16) + 3], expect, worst, checked, worstColour);
    EXPECT_TRUE(checked > 100);
    EXPECT_TRUE(worst < 1e-3);
    EXPECT_TRUE(worstColour < 1e-3);
    EXPECT_TRUE(outside == 0);
    EXPECT_TRUE(res.stats.samplesPlain >= res.stats.samplesEvaluated);
  }
}

NV_TEST(slab_transmittance_diagonal_chords)
{
  // Orthographic view along (1, 0, -1)/sqrt(2): the chord at horizontal offset s is 2 (sqrt(2) - |s|).
  const auto data = std::vector<float>(kN * kN * kN, 0.5f);
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  RenderRequest q = slabRequest(grid, 48, 8);
  const double eye[3] = { -3, 0, 3 }, c[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
  setCamera(q, mul(ortho(-1.5, 1.5, -0.25, 0.25, 0.5, 10.0), lookAt(eye, c, up)));
  q.sampleDistance = 1.0 / 512.0;
  RenderResult res;
  r.render(m, 1, q, res);
  const double sigma = slabSigma();
  double worst = 0;
  for (int px = 0; px < q.width; ++px)
  {
    const double s = -1.5 + 3.0 * (px + 0.5) / q.width;
    const double chord = std::max(0.0, 2.0 * (std::sqrt(2.0) - std::fabs(s)));
    const double expect = 1.0 - std::exp(-sigma * chord);
    worst = std::max(worst, std::fabs(res.rgba[4 * (4 * q.width + px) + 3] - expect));
  }
  std::printf("  diagonal chords: worst |alpha - analytic| = %.2e (dt = 1/512: bound %.2e)\n", worst, sigma / 512);
  EXPECT_TRUE(worst < sigma / 512.0);
}

NV_TEST(slab_collision_probability_delta_tracking)
{
  // Path tracing with no bounces: a path's alpha is 1 at its first real collision, so the mean alpha over the slab
  // pixels estimates 1 - exp(-sigma L). Without skipping the global majorant (the corner block's extinction) is
  // twice sigma: half the tentative collisions are null.
  const auto data = slabGrid();
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  RenderRequest q = slabRequest(grid, 32, 32);
  q.shading = ShadingMode::PathTrace;
  q.maxBounces = 0;
  q.samplesPerPixel = 64;
  const double expect = 1.0 - std::exp(-slabSigma() * 2.0);
  for (int skip = 0; skip < 2; ++skip)
  {
    q.emptySpaceSkipping = skip != 0;
    RenderResult res;
    r.render(m, 1, q, res);
    double sum = 0;
    int n = 0;
    for (int py = 0; py < q.height; ++py)
      for (int px = 0; px < q.width; ++px)
        if (slabPixel(px, py, q.width, q.height))
        {
          sum += res.rgba[4 * (py * q.width + px) + 3];
          ++n;
        }
    const double mean = sum / n, se = std::sqrt(expect * (1 - expect) / (double(n) * q.samplesPerPixel));
    std::printf("  skipping %d: mean alpha %.5f expected %.5f (standard error %.5f), %lld evaluations\n", skip, mean,
      expect, se, (long long)res.stats.samplesEvaluated);
    EXPECT_TRUE(std::fabs(mean - expect) < 4 * se);
  }
}

NV_TEST(path_tracing_and_nee_estimate_the_same_light)
{
  // A uniform slab lit by the sky only, then by the sky and a 60-degree sun: both estimators have low variance
  // here, so their means must agree closely. (This caught the NEE shadow ray handing its overshooting free-flight
  // number to the next segment: the sky-only NEE image came out 10% too bright at one bounce.)
  const auto data = std::vector<float>(kN * kN * kN, 0.5f);
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  for (int sun = 0; sun < 2; ++sun)
    for (int bounces = 1; bounces <= 3; bounces += 2)
    {
      double mean[2];
      for (int k = 0; k < 2; ++k)
      {
        RenderRequest q = slabRequest(grid, 16, 16);
        q.shading = k ? ShadingMode::PathTraceNee : ShadingMode::PathTrace;
        q.transfer.rgba = { 0.8f, 0.8f, 0.8f, 0.3f, 0.8f, 0.8f, 0.8f, 0.3f };
        const double eye[3] = { 2.2, 1.6, 2.9 }, c[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
        setCamera(q, mul(perspective(40.0, 1.0, 0.5, 20.0), lookAt(eye, c, up)));
        q.lightDirection[0] = 0.6;
        q.lightDirection[1] = 0.8;
        q.lightDirection[2] = 0.4;
        q.ambient = 0.3;
        q.diffuse = sun ? 0.8 : 0.0;
        q.sunAngle = 60.0;
        q.maxBounces = bounces;
        q.samplesPerPixel = 4096;
        RenderResult res;
        r.render(m, 1, q, res);
        mean[k] = meanChannel(res.rgba, 0);
      }
      std::printf("  %s, %d bounce(s): mean red PT %.5f, PT+NEE %.5f (ratio %.4f)\n", sun ? "sky + sun" : "sky only",
        bounces, mean[0], mean[1], mean[0] / mean[1]);
      EXPECT_NEAR_REL(mean[0], mean[1], sun ? 0.01 : 0.004, 0.0);
    }
}

NV_TEST(empty_transfer_function_is_transparent_and_skipped)
{
  const auto data = blobVolume(24);
  const VolumeView grid = viewOf(data, 24, 24, 24);
  Model m = gridModel(24);
  m.source.valueMin = grid.valueMin;
  m.source.valueMax = grid.valueMax;
  CpuRenderer r(pool());
  for (int mode = 0; mode < 5; ++mode)
    for (int path = 0; path < 3; ++path)
    {
      RenderRequest q = blobRequest(m, RenderPath(path), ShadingMode(mode), 24, 24);
      for (size_t i = 3; i < q.transfer.rgba.size(); i += 4)
        q.transfer.rgba[i] = 0.0f;
      q.samplesPerPixel = 2;
      q.grid = path == 0 ? &grid : nullptr;
      RenderResult on, off;
      r.render(m, 1, q, on);
      q.emptySpaceSkipping = false;
      r.render(m, 1, q, off);
      const bool clear = *std::max_element(on.rgba.begin(), on.rgba.end()) == 0.0f &&
        *std::max_element(off.rgba.begin(), off.rgba.end()) == 0.0f;
      EXPECT_TRUE(clear);
      EXPECT_TRUE(on.stats.samplesEvaluated == 0);
      // Without skipping a marcher still samples every step; trackers have a zero majorant and sample nothing.
      EXPECT_TRUE(mode >= 3 ? off.stats.samplesEvaluated == 0 : off.stats.samplesEvaluated > 1000);
      EXPECT_TRUE(r.macrocells().emptyCells() == r.macrocells().cellCount());
    }
}

NV_TEST(early_termination_cuts_samples)
{
  const auto data = slabGrid();
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  RenderRequest q = slabRequest(grid);
  q.transfer = slabTransfer(0.95f, 0.99f);
  RenderResult off, on;
  r.render(m, 1, q, off);
  q.terminationOpacity = 0.99;
  r.render(m, 1, q, on);
  double worst = 0;
  for (int py = 0; py < q.height; ++py)
    for (int px = 0; px < q.width; ++px)
      if (slabPixel(px, py, q.width, q.height))
      {
        worst = std::max(worst, double(std::fabs(on.rgba[4 * (py * q.width + px) + 3] - 1.0f)));
        EXPECT_TRUE(on.rgba[4 * (py * q.width + px) + 3] >= 0.99f);
      }
  const double ratio = double(on.stats.samplesEvaluated) / double(off.stats.samplesEvaluated);
  std::printf("  samples with termination at 0.99 / without: %lld / %lld = %.3f; plain %lld / %lld\n",
    (long long)on.stats.samplesEvaluated, (long long)off.stats.samplesEvaluated, ratio,
    (long long)on.stats.samplesPlain, (long long)off.stats.samplesPlain);
  // alpha per sample 1 - 0.05^(1/16) = 0.171: 0.99 after 25 of the 64 samples of a slab ray
  EXPECT_TRUE(ratio < 0.45);
  EXPECT_TRUE(worst < 0.011);
  EXPECT_TRUE(on.stats.samplesPlain == on.stats.samplesEvaluated); // nothing to skip in a full slab
}

NV_TEST(camera_inside_the_volume)
{
  const auto data = std::vector<float>(kN * kN * kN, 0.5f);
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  RenderRequest q = slabRequest(grid, 33, 33);
  const double eye[3] = { 0.1, 0.05, 0.2 }, c[3] = { 0.1, 0.05, -1.0 }, up[3] = { 0, 1, 0 };
  setCamera(q, mul(perspective(60.0, 1.0, 0.05, 10.0), lookAt(eye, c, up)));
  q.sampleDistance = 1.0 / 256.0;
  for (int path = 0; path < 3; ++path)
  {
    q.path = RenderPath(path);
    q.grid = path == 0 ? &grid : nullptr;
    RenderResult res;
    r.render(m, 1, q, res);
    int empty = 0;
    for (size_t i = 3; i < res.rgba.size(); i += 4)
      empty += res.rgba[i] > 0.05f ? 0 : 1;
    EXPECT_TRUE(empty == 0);
    EXPECT_TRUE(allFinite(res.rgba));
    if (path == 0)
    {
      // Centre pixel: from the near plane (z = 0.15) to the back face (z = -1), chord 1.15.
      const double expect = 1.0 - std::exp(-slabSigma() * 1.15);
      const float a = res.rgba[4 * (16 * 33 + 16) + 3];
      std::printf("  inside: centre alpha %.5f expected %.5f\n", a, expect);
      EXPECT_TRUE(std::fabs(a - expect) < 2e-3);
    }
  }
}

NV_TEST(parallel_and_perspective_cameras)
{
  // A constant box seen head-on: its silhouette is the front face. Orthographic [-1.5, 1.5]: pixels 11..52 of 64;
  // perspective from z = 4 with a 40 degree field: the face at distance 3 spans NDC +-(1/3)/tan(20) = +-0.9158,
  // pixels 3..60.
  const auto data = std::vector<float>(kN * kN * kN, 0.5f);
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  RenderRequest q = slabRequest(grid, 64, 64);
  const double eye[3] = { 0, 0, 4 }, c[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
  const Mat4 cams[2] = { mul(ortho(-1.5, 1.5, -1.5, 1.5, 0.5, 10.0), lookAt(eye, c, up)),
    mul(perspective(40.0, 1.0, 0.5, 10.0), lookAt(eye, c, up)) };
  const int lo[2] = { 11, 3 }, hi[2] = { 52, 60 };
  for (int k = 0; k < 2; ++k)
  {
    setCamera(q, cams[k]);
    RenderResult res;
    r.render(m, 1, q, res);
    int wrong = 0;
    for (int py = 0; py < 64; ++py)
      for (int px = 0; px < 64; ++px)
      {
        const bool inside = px >= lo[k] && px <= hi[k] && py >= lo[k] && py <= hi[k];
        wrong += (res.rgba[4 * (py * 64 + px) + 3] > 0.0f) == inside ? 0 : 1;
      }
    EXPECT_TRUE(wrong == 0);
    // Perspective: the centre ray crosses the full depth 2; a ray near the silhouette edge leaves through a side.
    const double centre = 1.0 - std::exp(-slabSigma() * 2.0);
    EXPECT_NEAR_REL(res.rgba[4 * (32 * 64 + 32) + 3], centre, 0.0, 2e-3);
  }
}

NV_TEST(depth_buffer_compositing)
{
  // Rows 0..7: no geometry (depth 1) -> unchanged; left half of the rest: geometry in front of the volume
  // (z = 1.5) -> transparent; right half: geometry at z = 0 -> the ray stops half way, alpha = 1 - exp(-sigma).
  const auto data = slabGrid();
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model trained = gridModel(kN);
  CpuRenderer r(pool());
  RenderRequest q = slabRequest(grid);
  const Mat4 vp = orthoDown();
  const double front[3] = { 0, 0, 1.5 }, mid[3] = { 0, 0, 0 };
  std::vector<float> depth(size_t(q.width) * q.height);
  for (int py = 0; py < q.height; ++py)
    for (int px = 0; px < q.width; ++px)
      depth[py * q.width + px] = py < 8 ? 1.0f : float(windowDepth(vp, px < q.width / 2 ? front : mid));
  for (int path = 0; path < 3; ++path)
  {
    q.path = RenderPath(path);
    q.grid = path == 0 ? &grid : nullptr;
    q.depth = nullptr;
    RenderResult plain, composited;
    r.render(trained, 1, q, plain);
    q.depth = depth.data();
    r.render(trained, 1, q, composited);
    int changed = 0, opaque = 0;
    double worst = 0;
    for (int py = 0; py < q.height; ++py)
      for (int px = 0; px < q.width; ++px)
      {
        const float* a = &plain.rgba[4 * (py * q.width + px)];
        const float* b = &composited.rgba[4 * (py * q.width + px)];
        if (py < 8)
          changed += std::memcmp(a, b, 16) == 0 ? 0 : 1;
        else if (px < q.width / 2)
          opaque += b[3] == 0.0f ? 0 : 1;
        else if (path == 0 && slabPixel(px, py, q.width, q.height))
          worst = std::max(worst, std::fabs(b[3] - (1.0 - std::exp(-slabSigma()))));
      }
    EXPECT_TRUE(changed == 0);
    EXPECT_TRUE(opaque == 0);
    EXPECT_TRUE(worst < 1e-3);
  }
}

NV_TEST(nan_holes_never_reach_the_image)
{
  // Holes where the field is ~0: a corner block and a two-sample-thick slab near z = -1 (samples between two NaN
  // slices have no valid corner: they are NaN), crossed by the rays after the blobs. Every mode and blend stays
  // finite; maximum intensity projection ignores the holes (before NaN samples were skipped, fmax(acc, NaN) lost
  // the maximum accumulated before the hole).
  const int n = 24;
  const auto clean = blobVolume(n);
  auto data = clean;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        if ((x < 6 && y < 6 && z < 6) || z == 1 || z == 2)
          data[(size_t(z) * n + y) * n + x] = std::numeric_limits<float>::quiet_NaN();
  const VolumeView grid = viewOf(data, n, n, n), cleanGrid = viewOf(clean, n, n, n);
  Model m = gridModel(n);
  m.source.valueMin = cleanGrid.valueMin;
  m.source.valueMax = cleanGrid.valueMax;
  CpuRenderer r(pool());
  for (int mode = 0; mode < 5; ++mode)
    for (int blend = 0; blend < 5; ++blend)
    {
      if (mode >= 3 && blend > 0)
        continue;
      RenderRequest q = blobRequest(m, RenderPath::Decode, ShadingMode(mode), 32, 32);
      q.blend = BlendMode(blend);
      q.averageRange[0] = m.source.valueMin + 0.2 * (m.source.valueMax - m.source.valueMin);
      q.averageRange[1] = m.source.valueMax;
      q.grid = &grid;
      q.samplesPerPixel = 4;
      RenderResult res, ref;
      r.render(m, 1, q, res);
      EXPECT_TRUE(allFinite(res.rgba));
      EXPECT_TRUE(meanChannel(res.rgba, 3) > 0.01 || blend == int(BlendMode::Minimum));
      if (blend == int(BlendMode::Maximum))
      {
        q.grid = &cleanGrid;
        r.render(m, 1, q, ref);
        const double p = psnr(res.rgba, ref.rgba);
        std::printf("  mode %d, maximum intensity with holes vs without: %.2f dB\n", mode, p);
        EXPECT_TRUE(p > 40.0);
      }
    }
}

NV_TEST(path_tracing_accumulation)
{
  const auto data = blobVolume(24);
  const VolumeView grid = viewOf(data, 24, 24, 24);
  Model m = gridModel(24);
  m.source.valueMin = grid.valueMin;
  m.source.valueMax = grid.valueMax;
  CpuRenderer r(pool());
  RenderRequest q = blobRequest(m, RenderPath::Decode, ShadingMode::PathTraceNee, 24, 24);
  q.grid = &grid;
  q.samplesPerPixel = 2;
  RenderResult a, b, c, first;
  r.render(m, 1, q, a);
  r.render(m, 1, q, b);
  r.render(m, 1, q, c);
  EXPECT_TRUE(a.stats.accumulatedFrames == 1 && b.stats.accumulatedFrames == 2 && c.stats.accumulatedFrames == 3);
  EXPECT_TRUE(a.rgba != b.rgba && b.rgba != c.rgba);
  // Frame 0 of any accumulation is the same image: a new request restarts from it.
  q.accumulate = false;
  r.render(m, 1, q, first);
  EXPECT_TRUE(first.stats.accumulatedFrames == 1 && first.rgba == a.rgba);
  q.accumulate = true;
  r.render(m, 1, q, b);
  EXPECT_TRUE(b.stats.accumulatedFrames == 2);
  // Any change restarts: the light, the network version, the image size.
  q.lightDirection[0] = -0.6;
  r.render(m, 1, q, c);
  EXPECT_TRUE(c.stats.accumulatedFrames == 1);
  r.render(m, 2, q, c);
  EXPECT_TRUE(c.stats.accumulatedFrames == 1);
  r.render(m, 2, q, c);
  EXPECT_TRUE(c.stats.accumulatedFrames == 2);
  q.width = 20;
  r.render(m, 2, q, c);
  EXPECT_TRUE(c.stats.accumulatedFrames == 1 && c.rgba.size() == 20 * 24 * 4);
  EXPECT_TRUE(c.stats.rays == 20 * 24 * 2);
}

NV_TEST(invalid_requests_throw)
{
  const auto data = slabGrid();
  const VolumeView grid = viewOf(data, kN, kN, kN);
  const Model m = gridModel(kN);
  CpuRenderer r(pool());
  const RenderRequest good = slabRequest(grid);
  RenderResult res;
  r.render(m, 1, good, res);
  // nv::Error (not any exception) with a message naming the problem.
  auto expectError = [](auto&& call, const char* message) {
    try
    {
      call();
      fail(__FILE__, __LINE__, std::string("no nv::Error for '") + message + "'");
    }
    catch (const Error& e)
    {
      if (std::string(e.what()).find(message) == std::string::npos)
        fail(__FILE__, __LINE__, std::string("message '") + e.what() + "' lacks '" + message + "'");
    }
    catch (const std::exception& e)
    {
      fail(__FILE__, __LINE__, std::string("not an nv::Error: ") + e.what());
    }
  };
  auto bad = [&](auto change, const char* message) {
    RenderRequest q = good;
    change(q);
    expectError([&] { r.render(m, 1, q, res); }, message);
  };
  bad([](RenderRequest& q) { q.width = q.height = 0; }, "image size 0 x 0");
  bad([](RenderRequest& q) { q.viewProjection[5] = NAN; }, "view-projection matrix is not finite");
  bad([](RenderRequest& q) { std::fill(q.viewProjection, q.viewProjection + 16, 0.0); }, "singular");
  bad([](RenderRequest& q) { q.worldToUnit[10] = 0.0; }, "volume transform is singular");
  bad([](RenderRequest& q) { q.transfer.rgba.resize(4); }, "at least 2 entries");
  bad([](RenderRequest& q) { q.transfer.rgba[1] = INFINITY; }, "non-finite values");
  bad([](RenderRequest& q) { q.transfer.unitDistance = 0.0; }, "unit distance");
  bad([](RenderRequest& q) { q.maxBounces = 100000; }, "max bounces");
  bad([](RenderRequest& q) { q.samplesPerPixel = 0; }, "samples per pixel");
  bad([](RenderRequest& q) { q.streamingSamples = 1 << 20; }, "streaming samples");
  bad([](RenderRequest& q) { q.sampleDistance = 1e-9; }, "samples across the volume");
  bad([](RenderRequest& q) { q.transfer.unitDistance = 1e-9; }, "opacity unit distance");
  bad([](RenderRequest& q) { q.shading = ShadingMode(7); }, "unknown shading mode");
  bad([](RenderRequest& q) { q.path = RenderPath::InShader; }, "Decode path only");
  bad([](RenderRequest& q) { q.decodeResolution[0] = -4; }, "decode resolution");
  Model empty;
  expectError([&] { r.render(empty, 1, good, res); }, "no parameters");
  // The renderer still works after every failure.
  RenderResult again;
  r.render(m, 1, good, again);
  EXPECT_TRUE(again.rgba == res.rgba || psnr(again.rgba, res.rgba) > 100);
}

NV_TEST_MAIN()
