// Quantisation-aware fine-tuning for 8-bit storage (TrainConfig::quantizationAwareFraction, the CPU trainer): the
// quantised forward the trainer uses is the stored 8-bit network itself (loss and gradient on a batch equal those of
// a trainer of the stored network, bit for bit; before the fine-tuning starts they are the float network's), and on a
// smooth field trained to about 40 dB, where 8-bit storage costs about a tenth of a dB, the stored network of a run
// with the fine-tuning is better than without, same seeds and steps (mean over three seeds).
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

using namespace nv;

namespace
{
constexpr int kN = 32;

const std::vector<float>& field()
{
  static const std::vector<float> f = nvtest::sampledCube(kN, [](double X, double Y, double Z) {
    return 100.0 + 40.0 * std::sin(4 * X) * std::cos(3 * Y) + 25.0 * std::sin(5 * Z + X);
  });
  return f;
}

Model freshModel()
{
  const VolumeView vol = nvtest::cubeView(field(), kN);
  Model m = nvtest::untrainedModel(nvtest::smallModelConfig(12), vol, 5);
  for (int a = 0; a < 3; ++a)
  {
    m.source.dims[a] = kN;
    m.source.bounds[2 * a + 1] = kN - 1;
  }
  m.source.rawBytes = int64_t(kN) * kN * kN * 4;
  return m;
}

TrainConfig config(int64_t steps, double fraction, uint64_t seed = 11)
{
  TrainConfig tc;
  tc.batchSize = 8192;
  tc.seed = seed;
  tc.threads = 2;
  tc.optimizer.schedule = LearningRateSchedule::Auto;
  tc.optimizer.plannedSteps = static_cast<double>(steps);
  tc.optimizer.holdSteps = 0;
  tc.quantizationAwareFraction = fraction;
  return tc;
}

/// A fixed batch of `n` samples of field() (network coordinates in [0,1]^3, normalised targets).
void batch(int64_t n, std::vector<float>& xyz, std::vector<float>& targets, std::vector<uint8_t>& valid)
{
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> cell(0, kN - 1);
  const std::vector<float>& f = field();
  float lo = f[0], hi = f[0];
  for (float v : f)
    lo = std::min(lo, v), hi = std::max(hi, v);
  xyz.resize(size_t(3 * n));
  targets.resize(size_t(n));
  valid.assign(size_t(n), 1);
  for (int64_t i = 0; i < n; ++i)
  {
    const int x = cell(rng), y = cell(rng), z = cell(rng);
    xyz[size_t(3 * i)] = float(x) / (kN - 1);
    xyz[size_t(3 * i + 1)] = float(y) / (kN - 1);
    xyz[size_t(3 * i + 2)] = float(z) / (kN - 1);
    targets[size_t(i)] = (f[size_t((z * kN + y) * kN + x)] - lo) / (hi - lo);
  }
}

/// PSNR of the network trained `steps` steps with `fraction` from `seed`, stored in 8 bits (and, in `floatPsnr`, in
/// fp32).
double storedPsnr(int64_t steps, double fraction, uint64_t seed, double& floatPsnr)
{
  const VolumeView vol = nvtest::cubeView(field(), kN);
  Model m = freshModel();
  auto tr = nvtest::createTrainer(Device::Cpu, m, vol, config(steps, fraction, seed));
  tr->steps(steps, nullptr);
  tr->syncTo(m);
  floatPsnr = nvtest::compareToSource(m, vol).psnr;
  m.quantize(Precision::Quantized8);
  return nvtest::compareToSource(m, vol).psnr;
}
} // namespace

NV_TEST(the_quantised_forward_is_the_stored_network)
{
  const VolumeView vol = nvtest::cubeView(field(), kN);
  const int64_t steps = 40;
  Model m = freshModel();
  auto tr = nvtest::createTrainer(Device::Cpu, m, vol, config(steps, 0.5));
  std::vector<float> xyz, targets;
  std::vector<uint8_t> valid;
  batch(4096, xyz, targets, valid);
  for (int64_t done : { int64_t(10), int64_t(30) }) // before the last half, then inside it
  {
    tr->steps(done - tr->stepsDone(), nullptr);
    std::vector<float> grad, storedGrad, floatGrad;
    const float loss = tr->lossAndGradient(xyz.data(), targets.data(), valid.data(), 4096, grad);
    Model now = m;
    tr->syncTo(now);
    Model stored = now;
    stored.quantize(Precision::Quantized8);
    auto storedTrainer = nvtest::createTrainer(Device::Cpu, stored, vol, config(steps, 0.0));
    auto floatTrainer = nvtest::createTrainer(Device::Cpu, now, vol, config(steps, 0.0));
    const float storedLoss = storedTrainer->lossAndGradient(xyz.data(), targets.data(), valid.data(), 4096, storedGrad);
    const float floatLoss = floatTrainer->lossAndGradient(xyz.data(), targets.data(), valid.data(), 4096, floatGrad);
    std::printf("  after %lld steps: loss %.7g, stored network's %.7g, float network's %.7g\n", (long long)done,
      double(loss), double(storedLoss), double(floatLoss));
    const bool fineTuning = done + 1 > steps / 2;
    EXPECT_TRUE(loss == (fineTuning ? storedLoss : floatLoss));
    EXPECT_TRUE(grad == (fineTuning ? storedGrad : floatGrad));
    EXPECT_TRUE(storedLoss != floatLoss); // the two forwards differ: the comparison above can fail
  }
}

NV_TEST(fine_tuning_raises_the_stored_networks_psnr)
{
  // The mean over three seeds (one seed's gain varies by several hundredths of a dB: the fine-tuning moves the
  // trajectory too).
  const int64_t steps = 600;
  double gain = 0.0, cost = 0.0;
  for (uint64_t seed : { 11, 12, 13 })
  {
    double floatPlain = 0.0, floatAware = 0.0;
    const double plain = storedPsnr(steps, 0.0, seed, floatPlain);
    const double aware = storedPsnr(steps, 0.5, seed, floatAware);
    std::printf("  seed %llu, %lld steps: 8-bit %.3f dB (float %.3f) without, %.3f dB (float %.3f) with the last "
                "half quantisation-aware: %+.3f dB\n",
      (unsigned long long)seed, (long long)steps, plain, floatPlain, aware, floatAware, aware - plain);
    EXPECT_TRUE(std::isfinite(plain) && std::isfinite(aware));
    gain += (aware - plain) / 3.0;
    cost += (floatPlain - plain) / 3.0;
  }
  std::printf("  mean: 8-bit storage costs %.3f dB without the fine-tuning; the fine-tuning gains %+.3f dB\n", cost,
    gain);
  EXPECT_TRUE(cost > 0.05); // 8-bit storage costs something here: room for the fine-tuning
  EXPECT_TRUE(gain > 0.05);
}

NV_TEST_MAIN()
