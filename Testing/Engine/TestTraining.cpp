// Training behaviour of the CPU engine: convergence, determinism, invalid samples, degenerate volumes.
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/PlateauSchedule.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

using namespace nv;
using nvtest::compareToSource;
using nvtest::createTrainer;
using nvtest::decodeGrid;
using nvtest::decodeGridNormalized;
using nvtest::inferPoints;

namespace
{
std::vector<float> analyticVolume(int n, double offset = 0.0)
{
  return nvtest::sampledCube(n, [offset](double X, double Y, double Z) {
    const double r2 = (X - .5) * (X - .5) + (Y - .5) * (Y - .5) + (Z - .5) * (Z - .5);
    return 100.0 * (std::sin(6 * X) * std::cos(5 * Y) + 0.5 * std::sin(7 * Z) + (r2 < 0.09 ? 0.8 : 0.0)) + offset;
  });
}

VolumeView view(const std::vector<float>& v, int n)
{
  return nvtest::cubeView(v, n);
}

ModelConfig smallConfig()
{
  return nvtest::smallModelConfig(14);
}

Model train(const VolumeView& vol, int steps, int threads, uint64_t seed, std::vector<float>* losses = nullptr)
{
  Model m = nvtest::untrainedModel(smallConfig(), vol, seed);
  TrainConfig tc;
  tc.batchSize = 8192;
  tc.seed = seed;
  tc.threads = threads;
  auto tr = createTrainer(Device::Cpu, m, vol, tc);
  for (int i = 0; i < steps; ++i)
  {
    const float l = tr->step();
    if (losses)
      losses->push_back(l);
  }
  tr->syncTo(m);
  EXPECT_TRUE(tr->stepsDone() == steps);
  return m;
}
} // namespace

NV_TEST(converges_on_analytic_field)
{
  const int n = 32;
  const auto data = analyticVolume(n);
  const VolumeView vol = view(data, n);
  std::vector<float> losses;
  const Model m = train(vol, 400, 2, 1, &losses);
  const ErrorStats e = compareToSource(m, vol, Device::Cpu, 2);
  std::printf("  analytic 32^3, 400 steps: PSNR %.2f dB, max error %.3f, loss %.5f -> %.5f\n", e.psnr,
    e.maxAbsError, losses.front(), losses.back());
  EXPECT_TRUE(e.count == int64_t(n) * n * n);
  EXPECT_TRUE(e.psnr > 35.0);
  EXPECT_TRUE(losses.back() < 0.1 * losses.front());
}

NV_TEST(deterministic_for_seed_and_threads)
{
  const int n = 24;
  const auto data = analyticVolume(n);
  const VolumeView vol = view(data, n);
  const Model a = train(vol, 20, 2, 7), b = train(vol, 20, 2, 7);
  EXPECT_TRUE(a.params() == b.params());
  const Model c = train(vol, 20, 2, 8);
  EXPECT_TRUE(a.params() != c.params());
  // Another thread count changes only the summation order of the MLP gradients: the fields stay close.
  const Model d = train(vol, 20, 1, 7);
  const ErrorStats ea = compareToSource(a, vol, Device::Cpu, 2), ed = compareToSource(d, vol, Device::Cpu, 2);
  EXPECT_NEAR_REL(ea.psnr, ed.psnr, 0.02, 0.0);
}

NV_TEST(steps_equal_repeated_step)
{
  // Trainer::steps(k, losses) is k steps with their losses: the same parameters and losses as k calls of step().
  const int n = 16;
  const auto data = analyticVolume(n);
  const VolumeView vol = view(data, n);
  Model m = nvtest::untrainedModel(smallConfig(), vol, 5);
  TrainConfig tc;
  tc.batchSize = 2048;
  tc.threads = 2;
  auto a = createTrainer(Device::Cpu, m, vol, tc), b = createTrainer(Device::Cpu, m, vol, tc);
  std::vector<float> la(12);
  a->steps(12, la.data());
  for (int i = 0; i < 12; ++i)
    EXPECT_TRUE(b->step() == la[i]);
  EXPECT_TRUE(a->stepsDone() == 12);
  Model ma = m, mb = m;
  a->syncTo(ma);
  b->syncTo(mb);
  EXPECT_TRUE(ma.params() == mb.params());
  a->steps(3, nullptr);
  EXPECT_TRUE(a->stepsDone() == 15);
}

NV_TEST(nan_and_inf_are_excluded)
{
  const int n = 24;
  auto data = analyticVolume(n);
  auto clean = data;
  int64_t bad = 0;
  for (size_t i = 0; i < data.size(); i += 97)
  {
    data[i] = (i % 2) ? std::numeric_limits<float>::quiet_NaN() : std::numeric_limits<float>::infinity();
    ++bad;
  }
  VolumeView vol = view(data, n);
  const VolumeStats s = computeStats(vol);
  EXPECT_TRUE(s.invalid == bad);
  const VolumeView cleanVol = view(clean, n);
  EXPECT_TRUE(std::isfinite(vol.valueMin) && std::isfinite(vol.valueMax));
  const Model m = train(vol, 300, 2, 3);
  std::vector<float> grid(data.size());
  decodeGrid(m, n, n, n, 0, n, grid.data(), Device::Cpu, 2);
  for (float g : grid)
    EXPECT_TRUE(std::isfinite(g));
  // Error over the valid voxels is close to that of training on the clean field.
  const ErrorStats e = compareDecoded(grid.data(), vol, vol.valueMin, vol.valueMax, 2);
  EXPECT_TRUE(e.count == int64_t(data.size()) - bad);
  const ErrorStats ec = compareToSource(train(cleanVol, 300, 2, 3), cleanVol, Device::Cpu, 2);
  std::printf("  with %lld invalid voxels: PSNR %.2f dB (clean %.2f dB)\n", (long long)bad, e.psnr, ec.psnr);
  EXPECT_TRUE(e.psnr > ec.psnr - 1.5);
}

NV_TEST(constant_field_is_exact)
{
  std::vector<int16_t> data(10 * 6 * 3, int16_t(-1234));
  VolumeView vol;
  vol.data = data.data();
  vol.type = ScalarType::Int16;
  vol.dims[0] = 10;
  vol.dims[1] = 6;
  vol.dims[2] = 3;
  const VolumeStats s = computeStats(vol);
  EXPECT_TRUE(s.min == -1234 && s.max == -1234);
  vol.valueMin = s.min;
  vol.valueMax = s.max;
  Model m(smallConfig());
  m.initialize(1);
  m.source.valueMin = s.min;
  m.source.valueMax = s.max;
  const ErrorStats e = compareToSource(m, vol, Device::Cpu, 1);
  EXPECT_TRUE(e.maxAbsError == 0.0 && e.mse == 0.0 && std::isinf(e.psnr));
}

NV_TEST(degenerate_and_typed_volumes_train)
{
  // A 2D image (nz = 1) in uint8 and a 1-voxel-thick double volume with a huge range.
  std::vector<uint8_t> img(40 * 30);
  for (size_t i = 0; i < img.size(); ++i)
    img[i] = uint8_t((i * 7) % 251);
  VolumeView v;
  v.data = img.data();
  v.type = ScalarType::UInt8;
  v.dims[0] = 40;
  v.dims[1] = 30;
  v.dims[2] = 1;
  VolumeStats s = computeStats(v);
  v.valueMin = s.min;
  v.valueMax = s.max;
  Model m = train(v, 30, 2, 1);
  ErrorStats e = compareToSource(m, v, Device::Cpu, 2);
  EXPECT_TRUE(std::isfinite(e.psnr) && e.count == 1200);

  std::vector<double> huge(16 * 16 * 2);
  for (size_t i = 0; i < huge.size(); ++i)
    huge[i] = (i % 16) * 1e300 - 5e300;
  v.data = huge.data();
  v.type = ScalarType::Float64;
  v.dims[0] = 16;
  v.dims[1] = 16;
  v.dims[2] = 2;
  s = computeStats(v);
  v.valueMin = s.min;
  v.valueMax = s.max;
  m = train(v, 200, 2, 1);
  e = compareToSource(m, v, Device::Cpu, 2);
  std::printf("  huge-range double volume: PSNR %.2f dB\n", e.psnr);
  EXPECT_TRUE(e.psnr > 20.0);
}

NV_TEST(table_size_from_target_ratio)
{
  ModelConfig c; // 16 x 4 levels, finest 4096
  c.encoding.finestResolution = 512;
  const int64_t raw = int64_t(128) * 128 * 256 * 2; // stent int16
  const int l = chooseLog2TableSize(c, raw, 4.0, Precision::Float16);
  c.encoding.log2TableSize = l;
  Model m(c);
  m.quantize(Precision::Float16);
  EXPECT_TRUE(double(raw) / m.parameterBytes() >= 4.0);
  c.encoding.log2TableSize = l + 1;
  Model bigger(c);
  bigger.quantize(Precision::Float16);
  EXPECT_TRUE(double(raw) / bigger.parameterBytes() < 4.0);
  EXPECT_TRUE(l == 14); // 2^14: 970,944 + 16,448 params in fp16 = 1.97 MB -> 4.25:1
}

namespace
{
/// A bank of `n` points at random positions with the analytic field's exact value there (normalised by the
/// volume's range), as an unstructured source probed at random points would give; every `nanEvery`-th is NaN.
struct Bank
{
  std::vector<float> xyz, values;
  nv::TrainingPoints view() const
  {
    nv::TrainingPoints p;
    p.xyz = xyz.data();
    p.values = values.data();
    p.count = int64_t(values.size());
    return p;
  }
};
double analyticValue(double X, double Y, double Z)
{
  const double r2 = (X - .5) * (X - .5) + (Y - .5) * (Y - .5) + (Z - .5) * (Z - .5);
  return 100.0 * (std::sin(6 * X) * std::cos(5 * Y) + 0.5 * std::sin(7 * Z) + (r2 < 0.09 ? 0.8 : 0.0));
}
Bank analyticBank(int64_t n, double lo, double hi, int64_t nanEvery)
{
  Bank b;
  b.xyz.resize(size_t(3 * n));
  b.values.resize(size_t(n));
  for (int64_t i = 0; i < n; ++i)
  {
    float* x = &b.xyz[size_t(3 * i)];
    randomPoint(99, 0, uint64_t(i), x);
    b.values[size_t(i)] = nanEvery > 0 && i % nanEvery == 0 ? std::numeric_limits<float>::quiet_NaN()
                                                            : float((analyticValue(x[0], x[1], x[2]) - lo) / (hi - lo));
  }
  return b;
}
} // namespace

NV_TEST(trains_from_a_bank_of_points)
{
  // Training from a bank of probed points (Neural Compress's Probe sampling, sparse OpenVDB grids) reaches the
  // accuracy of training from the volume itself: measured on the 32^3 grid of the same analytic field.
  const int n = 32;
  const auto data = analyticVolume(n);
  const VolumeView vol = view(data, n);
  const Bank bank = analyticBank(int64_t(1) << 17, vol.valueMin, vol.valueMax, 97);
  Model m = nvtest::untrainedModel(smallConfig(), vol, 1);
  TrainConfig tc;
  tc.batchSize = 8192;
  tc.seed = 1;
  tc.threads = 2;
  Model a = m, b = m;
  {
    auto tr = createTrainer(Device::Cpu, m, bank.view(), tc);
    std::vector<float> losses(400);
    tr->steps(400, losses.data());
    tr->syncTo(a);
    for (float l : losses)
      EXPECT_TRUE(std::isfinite(l)); // the NaN bank entries are never trained on
    EXPECT_TRUE(losses.back() < 0.1 * losses.front());
  }
  {
    auto tr = createTrainer(Device::Cpu, m, bank.view(), tc);
    tr->steps(400, nullptr);
    tr->syncTo(b);
  }
  EXPECT_TRUE(a.params() == b.params()); // a seed and thread count give the same network
  const ErrorStats e = compareToSource(a, vol, Device::Cpu, 2);
  const ErrorStats ref = compareToSource(train(vol, 400, 2, 1), vol, Device::Cpu, 2);
  std::printf("  analytic field, bank of 2^17 points, 400 steps: PSNR %.2f dB on the 32^3 grid (trained on the grid: "
              "%.2f dB)\n", e.psnr, ref.psnr);
  EXPECT_TRUE(e.psnr > 33.0);
  EXPECT_TRUE(e.psnr > ref.psnr - 3.0);

  // The draw covers the bank uniformly: 2^20 draws from 1000 entries, every entry drawn 1049 +- 5 sigma times.
  std::vector<int> hits(1000, 0);
  for (uint64_t i = 0; i < (1u << 20); ++i)
    ++hits[size_t(randomBankIndex(3, i >> 16, i & 0xFFFF, 1000))];
  int lo = 1 << 30, hi = 0;
  for (int h : hits)
  {
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  EXPECT_TRUE(lo > 1049 - 5 * 33 && hi < 1049 + 5 * 33);

  // An empty bank is refused.
  bool threw = false;
  try
  {
    const nv::TrainingPoints none;
    createTrainer(Device::Cpu, m, none, tc);
  }
  catch (const nv::Error&)
  {
    threw = true;
  }
  EXPECT_TRUE(threw);
}

NV_TEST(a_non_finite_output_is_never_a_score)
{
  // A diverged network (NaN or Inf where the source is valid) gives a NaN PSNR and an infinite max error, never
  // +inf and 0; an exact match is +inf, and NaN source samples do not count.
  const int n = 8;
  std::vector<float> src(size_t(n) * n * n), dec;
  for (size_t i = 0; i < src.size(); ++i)
    src[i] = float(i % 17);
  src[3] = std::numeric_limits<float>::quiet_NaN();
  VolumeView vol = view(src, n);
  dec = src;
  dec[3] = 5.0f; // under a NaN source sample: ignored
  ErrorStats e = compareDecoded(dec.data(), vol, vol.valueMin, vol.valueMax, 2);
  EXPECT_TRUE(std::isinf(e.psnr) && e.psnr > 0 && e.maxAbsError == 0.0 && e.nonFinite == 0);
  EXPECT_TRUE(e.count == int64_t(src.size()) - 1);
  dec[10] = std::numeric_limits<float>::quiet_NaN();
  dec[20] = std::numeric_limits<float>::infinity();
  e = compareDecoded(dec.data(), vol, vol.valueMin, vol.valueMax, 2);
  EXPECT_TRUE(std::isnan(e.psnr) && std::isnan(e.mse) && std::isinf(e.maxAbsError) && e.nonFinite == 2);
}

NV_TEST(plateau_schedule_halves_the_rate_on_a_plateau_only)
{
  OptimizerConfig o;
  o.plateauWindow = 10;
  PlateauSchedule p(o);
  auto feed = [&](float loss, int n) {
    for (int i = 0; i < n; ++i)
      p.observe(loss);
  };
  feed(1.0f, 10); // the first window sets the best
  EXPECT_TRUE(p.scale() == 1.0);
  feed(0.995f, 10); // 0.5% lower: not an improvement of 1%
  EXPECT_TRUE(p.scale() == 0.5);
  feed(0.5f, 10); // a real improvement keeps the rate
  EXPECT_TRUE(p.scale() == 0.5);
  feed(std::numeric_limits<float>::quiet_NaN(), 50); // non-finite losses are not counted
  EXPECT_TRUE(p.scale() == 0.5);
  feed(0.5f, 1000); // a long plateau: halved down to 1/64, no further
  EXPECT_TRUE(p.scale() == 1.0 / 64.0);
  OptimizerConfig off;
  PlateauSchedule q(off);
  for (int i = 0; i < 1000; ++i)
    q.observe(1.0f);
  EXPECT_TRUE(q.scale() == 1.0);

  // In the CPU trainer: the rate it reports is the schedule's times the factor, and a seed repeats bit for bit.
  const int n = 16;
  const auto data = analyticVolume(n);
  const VolumeView vol = view(data, n);
  auto run = [&](int window, double* rate) {
    Model m = nvtest::untrainedModel(smallConfig(), vol, 3);
    TrainConfig tc;
    tc.batchSize = 4096;
    tc.seed = 3;
    tc.threads = 2;
    tc.optimizer.plateauWindow = window;
    tc.optimizer.learningRate = 0.05; // oscillates on this field: the plateau schedule must act
    auto tr = createTrainer(Device::Cpu, m, vol, tc);
    for (int i = 0; i < 300; ++i)
      tr->step();
    *rate = tr->currentLearningRate();
    tr->syncTo(m);
    return m;
  };
  double r1 = 0, r2 = 0, r0 = 0;
  const Model a = run(5, &r1), b = run(5, &r2), c = run(0, &r0);
  std::printf("  plateau window 5: rate after 300 steps %.3g (schedule alone %.3g)\n", r1, r0);
  EXPECT_TRUE(a.params() == b.params() && r1 == r2);
  EXPECT_TRUE(r0 == 0.05);
  EXPECT_TRUE(r1 < r0 && r1 >= r0 / 64.0);
  EXPECT_TRUE(a.params() != c.params());
}

NV_TEST_MAIN()
