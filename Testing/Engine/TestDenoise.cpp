// The path-tracing denoiser (issue 24; Core/Denoise.h, Cpu/CpuDenoiser): a still path-traced picture converged in
// few paths. "Converged" is the bar of TestPathTracingConvergence: PSNR >= 35 dB against the picture of many paths
// (here PT+NEE, 1024 paths per pixel, the blob scene, the CPU engine's Decode path of an explicit grid).
//  - at 8 paths per pixel (one per render, as a still view accumulates) the denoised picture reaches the bar and the
//    raw one does not;
//  - at many paths (256) denoising does not increase the error;
//  - a NaN in the input stays in the output (never a good PSNR);
//  - the CPU denoiser equals a double-precision implementation of the algorithm (DenoiseFixtures.h) within 1e-5.
#include "DenoiseFixtures.h"
#include "RenderFixtures.h"
#include "TestHarness.h"

#include "Cpu/CpuDenoiser.h"

using namespace nv;
using namespace nvtest;

namespace
{
constexpr int kGrid = 48;
constexpr int kSize = 64;
constexpr int kReferencePaths = 1024;
constexpr int kFewPaths = 8;
constexpr int kManyPaths = 256;
constexpr double kConvergedDb = 35.0;
constexpr uint64_t kReferenceSeed = 12345; ///< the reference's paths are independent of the measured ones
constexpr double kReferenceTolerance = 1e-5; ///< CPU (float) against the double-precision implementation

ThreadPool& pool()
{
  static ThreadPool p(2);
  return p;
}

BlobGridScene& scene()
{
  static BlobGridScene s(kGrid);
  return s;
}

RenderRequest sceneRequest()
{
  return gridPathTracingRequest(scene().model, scene().grid, ShadingMode::PathTraceNee, kSize, kSize);
}

/// `paths` paths per pixel accumulated over renders of `perRender`; raw or denoised; `seed` of the random streams.
RenderResult accumulate(int paths, int perRender, bool denoise, uint64_t seed = 1)
{
  CpuRenderer r(pool());
  RenderRequest q = sceneRequest();
  q.seed = seed;
  q.samplesPerPixel = perRender;
  q.denoise = denoise;
  RenderResult res;
  for (int done = 0; done < paths; done += perRender)
    r.render(scene().model, 1, q, res);
  EXPECT_TRUE(res.stats.accumulatedPaths == paths && res.stats.denoised == denoise);
  return res;
}

const std::vector<float>& reference()
{
  static std::vector<float> img;
  if (img.empty())
    img = accumulate(kReferencePaths, 256, false, kReferenceSeed).rgba;
  return img;
}
} // namespace

NV_TEST(denoised_picture_converges_in_few_paths)
{
  const RenderResult raw = accumulate(kFewPaths, 1, false), denoised = accumulate(kFewPaths, 1, true);
  const double rawDb = psnr(raw.rgba, reference()), denoisedDb = psnr(denoised.rgba, reference());
  std::printf("  PT+NEE at %d paths per pixel against %d: raw %.2f dB, denoised %.2f dB (bar %.0f); denoise %.2f "
              "ms (the last render)\n",
    kFewPaths, kReferencePaths, rawDb, denoisedDb, kConvergedDb, denoised.stats.denoiseMilliseconds);
  EXPECT_TRUE(denoisedDb >= kConvergedDb);
  EXPECT_TRUE(rawDb < kConvergedDb);
  // One render of all the paths (a single frame: the spatial variance) converges too.
  const RenderResult once = accumulate(kFewPaths, kFewPaths, true);
  const double onceDb = psnr(once.rgba, reference());
  std::printf("  one render of %d paths, denoised: %.2f dB\n", kFewPaths, onceDb);
  EXPECT_TRUE(onceDb >= kConvergedDb);
}

NV_TEST(denoising_does_not_increase_the_error_at_many_paths)
{
  const RenderResult raw = accumulate(kManyPaths, 16, false), denoised = accumulate(kManyPaths, 16, true);
  const double rawDb = psnr(raw.rgba, reference()), denoisedDb = psnr(denoised.rgba, reference());
  std::printf("  %d paths per pixel (renders of 16): raw %.2f dB, denoised %.2f dB\n", kManyPaths, rawDb,
    denoisedDb);
  EXPECT_TRUE(denoisedDb >= rawDb);
}

NV_TEST(the_accumulation_stays_unfiltered)
{
  // Denoising only the image handed out: the raw accumulation of a denoising renderer equals a plain one (same
  // paths), so turning the property off mid-accumulation shows the raw average.
  CpuRenderer r(pool());
  RenderRequest q = sceneRequest();
  q.samplesPerPixel = 2;
  q.denoise = true;
  RenderResult a, b;
  r.render(scene().model, 1, q, a);
  r.render(scene().model, 1, q, a);
  q.denoise = false;
  r.render(scene().model, 1, q, a);
  const RenderResult plain = accumulate(6, 2, false);
  EXPECT_TRUE(a.stats.accumulatedPaths == 6 && !a.stats.denoised && a.rgba == plain.rgba);
}

NV_TEST(a_nan_is_never_smoothed_away)
{
  DenoiseInput in = syntheticDenoiseInput(48, 40, 8, 3);
  const std::vector<double> clean = referenceDenoise(in);
  const size_t bad = size_t(20) * 48 + 20; // inside the first disc
  EXPECT_TRUE(in.guide[4 * bad + 3] > 0.5f);
  in.noisy[4 * bad + 1] = NAN;
  std::vector<float> out(in.noisy.size());
  CpuDenoiser d;
  d.denoise(pool(), in.params, in.noisy.data(), in.guide.data(), in.moments.data(), out.data());
  EXPECT_TRUE(!std::isfinite(out[4 * bad + 1]));
  const std::vector<float> cleanF(clean.begin(), clean.end());
  EXPECT_TRUE(psnr(out, cleanF) < 0.0); // the harness's PSNR of an image with a NaN: -1, never a good figure
  size_t nonFinite = 0;
  for (float v : out)
    nonFinite += std::isfinite(v) ? 0 : 1;
  EXPECT_TRUE(nonFinite == 1); // ... and its neighbours are filtered without it
  in.moments[bad + 1] = NAN;   // a NaN moment: that pixel's variance is dropped, the image stays finite elsewhere
  d.denoise(pool(), in.params, in.noisy.data(), in.guide.data(), in.moments.data(), out.data());
  nonFinite = 0;
  for (float v : out)
    nonFinite += std::isfinite(v) ? 0 : 1;
  EXPECT_TRUE(nonFinite == 1);
}

NV_TEST(empty_background_does_not_make_the_picture_look_converged)
{
  // Step 4 (the fade to the raw accumulation) estimates the raw picture's error over the pixels the volume covers:
  // the same accumulation inside a frame three times as wide (empty background added) gives the same picture.
  // Over every pixel the background's zero variance would raise the estimate by 10 log10(3) = 4.8 dB.
  bool fadeBandSeen = false;
  for (int frames : { 40, 160, 640, 2560 })
  {
    const DenoiseInput in = syntheticDenoiseInput(48, 40, frames, 7);
    DenoiseInput wide = in;
    const int width = in.params.width, height = in.params.height, wideWidth = 3 * width;
    wide.params.width = wideWidth;
    wide.noisy.assign(size_t(4) * wideWidth * height, 0.0f);
    wide.guide.assign(size_t(4) * wideWidth * height, 0.0f);
    wide.moments.assign(size_t(wideWidth) * height, 0.0f);
    double sum = 0.0;
    int covered = 0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
      {
        const size_t i = size_t(y) * width + x, j = size_t(y) * wideWidth + x;
        std::copy(&in.noisy[4 * i], &in.noisy[4 * i] + 4, &wide.noisy[4 * j]);
        std::copy(&in.guide[4 * i], &in.guide[4 * i] + 4, &wide.guide[4 * j]);
        wide.moments[j] = in.moments[i];
        if (denoise::guideCovers(in.params, &in.guide[4 * i]))
        {
          sum += denoise::rawVarianceOfMean(in.params, &in.noisy[4 * i], in.moments[i]);
          ++covered;
        }
      }
    // Is this accumulation in the fade's band, where counting the background would change the picture?
    const float fadeCovered = denoise::fade(in.params, sum / covered);
    const float fadeAll = denoise::fade(in.params, sum / (double(wideWidth) * height));
    fadeBandSeen = fadeBandSeen || std::fabs(fadeCovered - fadeAll) > 0.05f;
    std::vector<float> out(in.noisy.size()), wideOut(wide.noisy.size());
    CpuDenoiser d;
    d.denoise(pool(), in.params, in.noisy.data(), in.guide.data(), in.moments.data(), out.data());
    d.denoise(pool(), wide.params, wide.noisy.data(), wide.guide.data(), wide.moments.data(), wideOut.data());
    double worst = 0.0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        for (int c = 0; c < 4; ++c)
          worst = std::max(worst, double(std::fabs(out[4 * (size_t(y) * width + x) + c] -
                                                   wideOut[4 * (size_t(y) * wideWidth + x) + c])));
    std::printf("  %d frames: fade %.2f (over every pixel of the wide frame it would be %.2f); max difference %.2e\n",
      frames, fadeCovered, fadeAll, worst);
    EXPECT_TRUE(worst <= 1e-5);
  }
  EXPECT_TRUE(fadeBandSeen); // the case exercises the difference
}

NV_TEST(cpu_denoiser_equals_the_double_precision_reference)
{
  for (int frames : { 1, 8, 40 }) // one frame: the spatial variance; several: the moments; 40: step 4 fades
  {
    const DenoiseInput in = syntheticDenoiseInput(53, 41, frames, 7);
    std::vector<float> out(in.noisy.size());
    CpuDenoiser d;
    d.denoise(pool(), in.params, in.noisy.data(), in.guide.data(), in.moments.data(), out.data());
    const std::vector<double> ref = referenceDenoise(in);
    const double diff = maxDifference(out, ref);
    const std::vector<float> refF(ref.begin(), ref.end());
    std::printf("  %d frame(s): max |CPU - double reference| %.2e (tolerance %.0e); the filter changed the image by "
                "%.2f dB PSNR\n",
      frames, diff, kReferenceTolerance, psnr(in.noisy, refF));
    EXPECT_TRUE(diff <= kReferenceTolerance);
    EXPECT_TRUE(psnr(in.noisy, refF) < 40.0); // it did filter (the comparison is not of two unfiltered images)
  }
}

NV_TEST_MAIN()
