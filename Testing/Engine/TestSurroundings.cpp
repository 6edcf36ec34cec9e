// RenderRequest::surroundings (MPI: shadows and path tracing across pieces). The blob split along x into two pieces
// as two ranks hold it (each its own grid with ghost layers, its own part the clip box), lit from the side of the
// back piece: each piece rendered with a coarse grid of the whole as its surroundings and composited front over back
// must match the whole picture -- with shadows and with path tracing + NEE -- and the band along the split must be no
// worse than the rest. Without the surroundings the back piece casts no shadow on the front one and the same check
// fails (the test asserts that too). Also: a bad grid is refused, a changed grid renders again.
//   nvTestSurroundings [case]
#include "Core/Error.h"
#include "Core/RenderSetup.h"
#include "Cpu/CpuRenderer.h"
#include "SurroundingsFixtures.h"
#include "TestHarness.h"

#include <algorithm>
#include <cmath>

using namespace nv;
using namespace nvtest;

namespace
{
ThreadPool& pool()
{
  static ThreadPool p(2);
  return p;
}

const SplitScene& scene()
{
  static SplitScene s;
  return s;
}

constexpr int kWidth = 72, kHeight = 56;
constexpr int kCoarse = 25; ///< the surroundings: every other sample of the 49^3 blob

std::vector<float> render(const SplitPiece& piece, ShadingMode mode, int spp,
  std::shared_ptr<const SurroundingsGrid> surroundings, uint64_t seed = 7)
{
  RenderRequest q = splitRequest(scene(), piece, mode, kWidth, kHeight, spp);
  q.surroundings = std::move(surroundings);
  q.seed = seed;
  CpuRenderer renderer(pool());
  RenderResult result;
  renderer.render(piece.model, 1, q, result);
  return result.rgba;
}

/// Differences below half an 8-bit level are invisible: the band's error is compared with the rest's or this,
/// whichever is larger (ray marching an exact grid, the rest of the composite is the whole picture to 1e-5, while
/// along the split the samples restart at the plane, as without shadows: engine.ClipBox).
constexpr double kInvisibleError = 0.5 / 255.0;

struct SplitFigures
{
  double psnr = 0.0;
  double band = 0.0, rest = 0.0;
  double ratio() const { return band / std::max(rest, kInvisibleError); }
};

/// The two pieces composited (with or without surroundings) against the whole picture. Path tracing: the pieces
/// draw their paths from another seed than the whole picture, so that the error is independent noise (plus any
/// bias) everywhere -- with one seed a pixel that one piece covers alone repeats the whole picture's paths, and
/// only the band would carry independent noise.
SplitFigures compareSplit(ShadingMode mode, int spp, bool withSurroundings)
{
  const SplitScene& s = scene();
  const std::vector<float> whole = render(s.whole, mode, spp, nullptr, 7);
  const std::vector<float> back =
    render(s.low, mode, spp, withSurroundings ? coarseSurroundings(s.low, kCoarse) : nullptr, 11);
  const std::vector<float> front =
    render(s.high, mode, spp, withSurroundings ? coarseSurroundings(s.high, kCoarse) : nullptr, 11);
  const std::vector<float> composite = compositeOver(front, back);
  SplitFigures f;
  f.psnr = psnr(composite, whole);
  bandErrors(composite, whole, splitBand(splitCamera(kWidth, kHeight), kWidth, kHeight, 2), f.band, f.rest);
  std::printf("  %s, %s surroundings: composite vs whole %.2f dB, mean |error| band %.4f, rest %.4f (%.2fx)\n",
    shadingModeName(mode), withSurroundings ? "with" : "without", f.psnr, f.band, f.rest, f.ratio());
  return f;
}

/// The check: the composite within `minPsnr` of the whole and the band no worse than 1.5x the rest.
bool seamless(const SplitFigures& f, double minPsnr)
{
  return f.psnr >= minPsnr && f.ratio() <= 1.5;
}
} // namespace

NV_TEST(shadows_across_pieces_match_the_whole_picture)
{
  const SplitFigures with = compareSplit(ShadingMode::RayMarchShadows, 1, true);
  const SplitFigures without = compareSplit(ShadingMode::RayMarchShadows, 1, false);
  // Measured: 61.0 dB, band 0.78x with; 39.2 dB, band 9.2x without.
  EXPECT_TRUE(seamless(with, 45.0));
  EXPECT_TRUE(!seamless(without, 45.0));
}

NV_TEST(path_tracing_nee_across_pieces_matches_the_whole_picture)
{
  const SplitFigures with = compareSplit(ShadingMode::PathTraceNee, 256, true);
  const SplitFigures without = compareSplit(ShadingMode::PathTraceNee, 256, false);
  // Measured: 42.2 dB, band 0.95x with (two whole pictures of other seeds: 42.2 dB, the noise); 33.5 dB, band 3.2x
  // without.
  EXPECT_TRUE(seamless(with, 38.0));
  EXPECT_TRUE(!seamless(without, 38.0));
}

NV_TEST(every_path_shadows_across_halves_of_a_network)
{
  // A network of the whole blob, its halves x < 0.5 and x > 0.5 drawn apart (clip boxes) with the coarse grid as
  // their surroundings, composited: the whole network's picture on every render path (the network's own values
  // inside each half, the grid's beyond it: their difference shows in the shadows, not as a seam).
  const SplitScene& s = scene();
  static Model model = trainModel(viewOf(s.data, kSplitGrid, kSplitGrid, kSplitGrid), smallRenderConfig(), 300, 4096);
  const std::shared_ptr<const SurroundingsGrid> grid = coarseSurroundings(s.whole, kCoarse);
  const std::vector<uint8_t> band = splitBand(splitCamera(kWidth, kHeight), kWidth, kHeight, 2);
  for (int path = 0; path < 3; ++path)
  {
    auto draw = [&](double lo, double hi, std::shared_ptr<const SurroundingsGrid> surroundings) {
      RenderRequest q = splitRequest(s, s.whole, ShadingMode::RayMarchShadows, kWidth, kHeight, 1);
      q.grid = nullptr;
      q.path = RenderPath(path);
      q.clipBox[0] = lo;
      q.clipBox[1] = hi;
      q.surroundings = std::move(surroundings);
      CpuRenderer renderer(pool());
      RenderResult result;
      renderer.render(model, 1, q, result);
      return result.rgba;
    };
    const std::vector<float> whole = draw(0.0, 1.0, nullptr);
    for (int withGrid = 1; withGrid >= 0; --withGrid)
    {
      const std::vector<float> composite =
        compositeOver(draw(0.5, 1.0, withGrid ? grid : nullptr), draw(0.0, 0.5, withGrid ? grid : nullptr));
      SplitFigures f;
      f.psnr = psnr(composite, whole);
      bandErrors(composite, whole, band, f.band, f.rest);
      std::printf("  %s, %s surroundings: composite vs whole %.2f dB, band %.4f, rest %.4f (%.2fx)\n",
        renderPathName(RenderPath(path)), withGrid ? "with" : "without", f.psnr, f.band, f.rest, f.ratio());
      EXPECT_TRUE(withGrid ? seamless(f, 40.0) : !seamless(f, 40.0));
    }
  }
}

NV_TEST(emission_absorption_ignores_the_surroundings)
{
  // Primary rays march the clip box only: a mode without secondary rays draws the same picture with or without them.
  const SplitScene& s = scene();
  const std::vector<float> plain = render(s.high, ShadingMode::RayMarch, 1, nullptr);
  const std::vector<float> with = render(s.high, ShadingMode::RayMarch, 1, coarseSurroundings(s.high, kCoarse));
  EXPECT_TRUE(plain == with);
}

NV_TEST(a_changed_grid_renders_again)
{
  const SplitScene& s = scene();
  RenderRequest q = splitRequest(s, s.high, ShadingMode::PathTraceNee, 16, 12, 1);
  q.surroundings = coarseSurroundings(s.high, kCoarse);
  CpuRenderer renderer(pool());
  RenderResult r;
  renderer.render(s.high.model, 1, q, r);
  renderer.render(s.high.model, 1, q, r);
  EXPECT_TRUE(r.stats.accumulatedFrames == 2);
  // Another grid with other values (an opaque slab): the accumulation starts over; a copy of the same values not.
  auto other = std::make_shared<SurroundingsGrid>(*q.surroundings);
  other->values.assign(other->values.size(), float(s.whole.model.source.valueMax));
  const uint64_t before = renderKey(q);
  q.surroundings = std::make_shared<SurroundingsGrid>(*q.surroundings);
  EXPECT_TRUE(renderKey(q) == before);
  q.surroundings = other;
  EXPECT_TRUE(renderKey(q) != before);
  renderer.render(s.high.model, 1, q, r);
  EXPECT_TRUE(r.stats.accumulatedFrames == 1);
  // Ray marching with shadows: not the cached image.
  q.shading = ShadingMode::RayMarchShadows;
  renderer.render(s.high.model, 1, q, r);
  q.surroundings = coarseSurroundings(s.high, kCoarse);
  renderer.render(s.high.model, 1, q, r);
  EXPECT_TRUE(!r.stats.reused);
}

NV_TEST(a_bad_grid_is_refused)
{
  const SplitScene& s = scene();
  RenderRequest q = splitRequest(s, s.high, ShadingMode::RayMarchShadows, 16, 12, 1);
  auto g = std::make_shared<SurroundingsGrid>(*coarseSurroundings(s.high, kCoarse));
  q.surroundings = g;
  validate(q);
  g->dims[1] = 1;
  EXPECT_THROW_MSG(validate(q), "2..65536 samples per axis");
  g->dims[1] = kCoarse;
  g->values.pop_back();
  EXPECT_THROW_MSG(validate(q), "values for");
  g->values.push_back(0.0f);
  g->box[3] = std::nan("");
  EXPECT_THROW_MSG(validate(q), "surroundings box");
  g->box[3] = g->box[2];
  EXPECT_THROW_MSG(validate(q), "surroundings box");
  g->box[3] = 1e30;
  // A box so large that a shadow ray would take too many steps across it.
  CpuRenderer renderer(pool());
  RenderResult r;
  EXPECT_THROW_MSG(renderer.render(s.high.model, 1, q, r), "samples across the volume");
}

NV_TEST_MAIN()
