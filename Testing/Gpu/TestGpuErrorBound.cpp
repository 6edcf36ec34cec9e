// MaxError on both engines (ctest gpu.ErrorBound): corrections computed from one device's decode keep the bound on
// the other's (the 10% margin of Core/ErrorCorrections.h covers the GPU's fp16 MLP), the CUDA session keeps them
// until a trainer publishes, and the list round-trips through the file unchanged. Skips (77) without a usable GPU.
#include "Core/Engine.h"
#include "Core/ErrorCorrections.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"
#include "Gpu/GpuEngine.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using namespace nv;

namespace
{
constexpr int kSkip = 77;
constexpr int kN = 40;

std::vector<float> field()
{
  return nvtest::sampledCube(kN, [](double X, double Y, double Z) {
    const double r2 = (X - .4) * (X - .4) + (Y - .55) * (Y - .55) + (Z - .5) * (Z - .5);
    return 50.0 * std::sin(5 * X) * std::cos(4 * Y) + 30.0 * std::sin(6 * Z) + (r2 < 0.06 ? 40.0 : 0.0);
  });
}

/// |decoded - source| at every sample, decoded in float by `device`.
double maxError(const Model& m, const std::vector<float>& src, Device device)
{
  auto s = nvtest::session(m, device);
  std::vector<float> out(src.size());
  decodeGridValues(*s, kN, kN, kN, 0, kN, out.data());
  double worst = 0.0;
  for (size_t i = 0; i < src.size(); ++i)
  {
    const double e = std::fabs(double(out[i]) - double(src[i]));
    worst = std::isfinite(e) ? std::max(worst, e) : INFINITY;
  }
  return worst;
}
} // namespace

NV_TEST(bound_holds_across_devices)
{
  const std::vector<float> src = field();
  const VolumeView vol = nvtest::cubeView(src, kN);
  Model m = nvtest::untrainedModel(nvtest::smallModelConfig(13), vol, 4);
  for (int a = 0; a < 3; ++a)
  {
    m.source.dims[a] = kN;
    m.source.bounds[2 * a + 1] = kN - 1;
  }
  TrainConfig tc;
  tc.batchSize = 16384;
  tc.seed = 4;
  auto t = nvtest::createTrainer(Device::Cpu, m, vol, tc);
  t->steps(300, nullptr);
  t->syncTo(m);
  m.quantize(Precision::Float16);
  const double bound = 0.003 * (vol.valueMax - vol.valueMin);
  for (Device from : { Device::Cpu, Device::Cuda })
  {
    auto s = nvtest::session(m, from);
    std::vector<double> decoded(src.size());
    decodeGridValues(*s, kN, kN, kN, 0, kN, decoded.data());
    Model b = m;
    b.corrections = computeCorrections(decoded.data(), vol, bound);
    b = deserialize(serialize(b));
    const double cpu = maxError(b, src, Device::Cpu), gpu = maxError(b, src, Device::Cuda);
    std::printf("  corrections from the %s decode: %lld; max error cpu %.5g gpu %.5g (bound %.5g, unbounded %.5g)\n",
      deviceName(from), (long long)b.corrections.count(), cpu, gpu, bound, maxError(m, src, Device::Cuda));
    EXPECT_TRUE(b.corrections.count() > 0);
    EXPECT_TRUE(cpu <= bound && gpu <= bound);
  }
  // The CUDA session keeps them until a trainer publishes.
  Model b = m;
  b.corrections = computeCorrections(std::vector<double>(src.size(), 0.0).data(), vol, bound);
  auto s = nvtest::session(b, Device::Cuda);
  EXPECT_TRUE(s->errorCorrections() && s->errorCorrections()->count() == b.corrections.count());
  auto g = s->createTrainer(vol, tc);
  g->step();
  g->publish();
  EXPECT_TRUE(s->errorCorrections() == nullptr && !s->currentModel().corrections.enabled());
}

int main(int argc, char** argv)
{
  std::string why;
  if (!gpu::deviceUsable(&why))
  {
    std::printf("SKIPPED: no usable GPU (%s)\n", why.c_str());
    return kSkip;
  }
  return nvtest::runCases(argc, argv);
}
