// RenderRequest::clipBox (MPI: a rank draws only its own piece of a network trained with ghost layers around it):
// the two halves of the box z < 0.5 and z > 0.5, drawn apart and composited front over back, are the picture of the
// whole box; a half draws nothing beyond its plane; an empty or outside box is an error.
//   nvTestClipBox [case]
#include "Core/Error.h"
#include "Core/RenderSetup.h"
#include "Cpu/CpuRenderer.h"
#include "RenderFixtures.h"
#include "TestHarness.h"

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

constexpr int kGrid = 40;

const Model& blobModel()
{
  static std::vector<float> data = blobVolume(kGrid);
  static Model model = trainModel(viewOf(data, kGrid, kGrid, kGrid), smallRenderConfig(), 300, 4096);
  return model;
}

RenderResult renderClipped(RenderPath path, double zLo, double zHi)
{
  const Model& model = blobModel();
  RenderRequest q = blobRequest(model, path, ShadingMode::RayMarch, 48, 40);
  setCamera(q, orthoAlongZ()); // the eye at +z: the half z > 0.5 is in front
  q.clipBox[4] = zLo;
  q.clipBox[5] = zHi;
  CpuRenderer renderer(pool());
  RenderResult result;
  renderer.render(model, 1, q, result);
  return result;
}
} // namespace

NV_TEST(two_halves_composite_to_the_whole)
{
  for (int path = 0; path < 3; ++path)
  {
    const RenderResult whole = renderClipped(RenderPath(path), 0.0, 1.0);
    const RenderResult back = renderClipped(RenderPath(path), 0.0, 0.5);
    const RenderResult front = renderClipped(RenderPath(path), 0.5, 1.0);
    double squared = 0.0, largest = 0.0, alphaWhole = 0.0, alphaBack = 0.0, alphaFront = 0.0;
    const size_t n = whole.rgba.size();
    for (size_t k = 0; k < n; k += 4)
    {
      for (int c = 0; c < 4; ++c)
      {
        // Premultiplied "over": the front half, then what the back half lets through.
        const double over = front.rgba[k + c] + (1.0 - front.rgba[k + 3]) * back.rgba[k + c];
        const double e = over - whole.rgba[k + c];
        squared += e * e;
        largest = std::max(largest, std::fabs(e));
      }
      alphaWhole += whole.rgba[k + 3];
      alphaBack += back.rgba[k + 3];
      alphaFront += front.rgba[k + 3];
    }
    const double psnr = 10.0 * std::log10(1.0 / (squared / double(n)));
    std::printf("  path %d: halves composited vs whole: PSNR %.1f dB, max |error| %.4f; summed alpha whole %.1f, "
                "back %.1f, front %.1f\n", path, psnr, largest, alphaWhole, alphaBack, alphaFront);
    // Both halves draw something, neither draws the whole, and together they are the whole (a sample's position
    // along a ray restarts at the plane: not bit for bit).
    EXPECT_TRUE(alphaBack > 0.05 * alphaWhole && alphaFront > 0.05 * alphaWhole);
    EXPECT_TRUE(alphaBack < 0.95 * alphaWhole && alphaFront < 0.95 * alphaWhole);
    EXPECT_TRUE(psnr >= 40.0 && largest <= 0.05);
  }
}

NV_TEST(a_box_outside_the_unit_box_is_an_error)
{
  const Model& model = blobModel();
  RenderRequest q = blobRequest(model, RenderPath::Decode, ShadingMode::RayMarch, 16, 16);
  q.clipBox[4] = 0.6;
  q.clipBox[5] = 0.4;
  EXPECT_THROW_MSG(validate(q), "clip box");
  q.clipBox[4] = 1.0;
  q.clipBox[5] = 2.0;
  EXPECT_THROW_MSG(validate(q), "clip box");
  q.clipBox[4] = 0.0;
  q.clipBox[5] = std::nan("");
  EXPECT_THROW_MSG(validate(q), "clip box");
}

NV_TEST_MAIN()
