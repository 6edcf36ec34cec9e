// Error-guided training samples (TrainConfig::importanceGrid, Core/ImportanceGrid.h): the draw follows the cell
// weights, a seed gives the same network bit for bit, and training on a mostly empty volume reaches a PSNR bound.
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Cpu/CpuImportance.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

using namespace nv;
using nvtest::compareToSource;
using nvtest::createTrainer;

namespace
{
/// n^3 volume, zero except a detailed blob in a sphere of radius 0.22 around (0.3, 0.35, 0.4): ~5% of the voxels.
std::vector<float> mostlyEmptyVolume(int n)
{
  return nvtest::sampledCube(n, [](double X, double Y, double Z) {
    const double r2 = (X - .3) * (X - .3) + (Y - .35) * (Y - .35) + (Z - .4) * (Z - .4);
    return r2 < 0.22 * 0.22 ? 50.0 + 40.0 * std::sin(23 * X) * std::cos(19 * Y) * std::sin(17 * Z + 1.0) : 0.0;
  });
}

VolumeView view(const std::vector<float>& v, int n)
{
  return nvtest::cubeView(v, n);
}

ModelConfig smallConfig()
{
  return nvtest::smallModelConfig(12);
}

Model train(const VolumeView& vol, int steps, int importance, uint64_t seed = 5)
{
  Model m = nvtest::untrainedModel(smallConfig(), vol, seed);
  TrainConfig tc;
  tc.batchSize = 4096;
  tc.seed = seed;
  tc.threads = 2;
  tc.importanceGrid = importance;
  auto tr = createTrainer(Device::Cpu, m, vol, tc);
  for (int i = 0; i < steps; ++i)
    tr->step();
  tr->syncTo(m);
  return m;
}
} // namespace

NV_TEST(draw_follows_weights)
{
  const int G = 4, cells = G * G * G;
  CpuImportance imp;
  imp.reset(G, 1);
  // Empty CDF (before the first refresh): every point is randomPoint's.
  for (uint64_t i = 0; i < 64; ++i)
  {
    float a[3], b[3];
    imp.point(9, 3, i, a);
    randomPoint(9, 3, i, b);
    EXPECT_TRUE(std::memcmp(a, b, sizeof a) == 0);
  }
  // Known weights: cell c gets (c % 5) (0 for a fifth of the cells), cell 7 ten times more.
  std::vector<float> w(cells);
  double total = 0.0;
  for (int c = 0; c < cells; ++c)
  {
    w[c] = c == 7 ? 0.4f : 0.01f * float(c % 5);
    total += double(importanceQuantize(w[c]));
  }
  imp.setWeights(w);
  const int64_t N = 400000;
  std::vector<int64_t> count(cells, 0);
  int64_t outside = 0;
  for (int64_t i = 0; i < N; ++i)
  {
    float x[3];
    imp.point(11, 42, uint64_t(i), x);
    for (int d = 0; d < 3; ++d)
      outside += (x[d] >= 0.0f && x[d] < 1.0f) ? 0 : 1;
    if (i % 2 == 0)
    {
      float r[3];
      randomPoint(11, 42, uint64_t(i), r); // even samples stay uniform
      EXPECT_TRUE(std::memcmp(x, r, sizeof x) == 0);
      continue;
    }
    ++count[importanceCell(x, G)];
  }
  EXPECT_TRUE(outside == 0);
  // Chi-square over the cells with weight; cells without weight receive no importance sample at all.
  double chi2 = 0.0;
  int df = -1;
  for (int c = 0; c < cells; ++c)
  {
    const double expected = double(N / 2) * double(importanceQuantize(w[c])) / total;
    if (expected == 0.0)
    {
      EXPECT_TRUE(count[c] == 0);
      continue;
    }
    chi2 += (count[c] - expected) * (count[c] - expected) / expected;
    ++df;
  }
  std::printf("  chi-square %.1f for %d degrees of freedom; cell 7: %lld of %lld\n", chi2, df, (long long)count[7],
    (long long)(N / 2));
  // df ~ 50: mean df, sd sqrt(2 df) = 10; a wrong draw (e.g. uniform) gives thousands.
  EXPECT_TRUE(chi2 < df + 6.0 * std::sqrt(2.0 * df));
  EXPECT_NEAR_REL(double(count[7]), double(N / 2) * importanceQuantize(w[7]) / total, 0.03, 0.0);
}

NV_TEST(refresh_is_the_mean_error_in_fixed_point)
{
  // The weights are the moving average of the mean |error| per cell; integer sums: the worker split does not matter.
  CpuImportance a, b;
  a.reset(2, 1);
  b.reset(2, 3);
  const float p0[3] = { 0.1f, 0.1f, 0.1f }, p7[3] = { 0.9f, 0.9f, 0.9f };
  const float errs[4] = { 0.1f, 0.3f, 0.25f, 0.05f };
  for (int k = 0; k < 4; ++k)
  {
    a.add(0, p0, errs[k]);
    b.add(k % 3, p0, errs[k]);
  }
  a.add(0, p7, 0.5f);
  b.add(2, p7, 0.5f);
  a.refresh();
  b.refresh();
  EXPECT_TRUE(a.weights() == b.weights());
  EXPECT_NEAR_REL(a.weights()[0], 0.175, 1e-5, 0.0);
  EXPECT_NEAR_REL(a.weights()[7], 0.5, 1e-5, 0.0);
  EXPECT_TRUE(a.weights()[3] < 0.0f); // never measured
  EXPECT_TRUE(a.cdf()[7] == importanceQuantize(a.weights()[0]) + importanceQuantize(a.weights()[7]));
  // Second refresh: moving average towards the new mean; a cell without samples keeps its weight.
  a.add(0, p7, 0.1f);
  a.refresh();
  EXPECT_NEAR_REL(a.weights()[7], 0.5 + kImportanceEma * (0.1 - 0.5), 1e-5, 0.0);
  EXPECT_NEAR_REL(a.weights()[0], 0.175, 1e-5, 0.0);
}

NV_TEST(same_seed_same_network)
{
  const int n = 24;
  const auto data = mostlyEmptyVolume(n);
  const VolumeView vol = view(data, n);
  const int steps = 3 * kImportanceInterval + 5; // three refreshes
  const Model a = train(vol, steps, 8), b = train(vol, steps, 8), off = train(vol, steps, 0);
  EXPECT_TRUE(a.params() == b.params());
  EXPECT_TRUE(a.params() != off.params()); // the draw changed after the first refresh
  // Identical to uniform sampling until the first refresh.
  EXPECT_TRUE(train(vol, kImportanceInterval, 8).params() == train(vol, kImportanceInterval, 0).params());
}

NV_TEST(trains_a_mostly_empty_volume)
{
  const int n = 40;
  const auto data = mostlyEmptyVolume(n);
  const VolumeView vol = view(data, n);
  const Model on = train(vol, 300, 8), off = train(vol, 300, 0);
  const ErrorStats eOn = compareToSource(on, vol, Device::Cpu, 2), eOff = compareToSource(off, vol, Device::Cpu, 2);
  std::printf("  mostly empty 40^3, 300 steps: PSNR %.2f dB with importance 8^3, %.2f dB uniform\n", eOn.psnr,
    eOff.psnr);
  EXPECT_TRUE(eOn.psnr > 36.0);
  EXPECT_TRUE(eOn.psnr > eOff.psnr + 1.0); // measured 38.5 vs 36.0 dB
}

NV_TEST(validates_grid_size)
{
  TrainConfig tc;
  tc.importanceGrid = 1;
  EXPECT_THROW_MSG(validate(tc), "importance grid");
  tc.importanceGrid = 65;
  EXPECT_THROW_MSG(validate(tc), "importance grid");
  tc.importanceGrid = 16;
  validate(tc);
}

NV_TEST_MAIN()
