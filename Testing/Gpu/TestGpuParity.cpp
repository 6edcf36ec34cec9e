// GPU engine parity tests (ctest label gpu): the CUDA kernels against the CPU engine on random inputs.
// Exits with kSkip (registered as SKIP_RETURN_CODE) when no usable GPU is present.
#include "Core/Engine.h"
#include "Cpu/CpuHashGrid.h"
#include "Cpu/CpuInference.h"
#include "Cpu/CpuSampler.h"
#include "Cpu/CpuTrainer.h"
#include "Gpu/GpuEngine.h"
#include "GpuTestHooks.h"
#include "KernelFlags.h"
#include "MirrorBatchSource.h"
#include "SessionHelpers.h"
#include "TestHarness.h"
#include "TestVolumeView.h"

#include <cmath>
#include <cstring>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

using namespace nv;
using nvtest::compareToSource;
using nvtest::createTrainer;
using nvtest::decodeGrid;
using nvtest::decodeGridNormalized;
using nvtest::inferPoints;

namespace
{
constexpr int kSkip = 77;

// Tolerances (relative error ||gpu - cpu|| / ||cpu||). The GPU keeps an fp16 copy of the table and runs the MLP
// on fp16 tensor cores with fp32 accumulation; the CPU is fp32 throughout.
constexpr double kTolEncoding = 2e-3; // fp16 rounding of table entries (2^-11 relative)
constexpr double kTolOutput = 1e-2;   // + fp16 activations and weights through up to 8 layers
constexpr double kTolLoss = 1e-2;
// Gradients: fp16 forward activations flip the ReLU mask of the rare pre-activations within rounding of 0; each
// flip is a full-size difference, so the error grows with depth: 4% + 0.6% per hidden layer.
double tolGrad(int hidden)
{
  return 0.04 + 0.006 * hidden;
}

struct Shape
{
  int F, W, H, L, log2T, base, finest;
};

const Shape kShapes[] = {
  { 1, 16, 1, 8, 12, 4, 64 },      // small, mostly dense
  { 2, 32, 2, 16, 14, 16, 512 },   // stent configuration family
  { 4, 64, 4, 16, 19, 16, 4096 },  // the paper configuration
  { 8, 128, 8, 32, 16, 8, 2048 },  // widest: 256 inputs, 8 layers
  { 4, 128, 3, 12, 22, 16, 1024 }, // big table
  { 2, 64, 8, 5, 13, 2, 40 },      // D=10 (padded to 16), dense only
  { 8, 16, 5, 3, 12, 16, 300 },    // narrow, D=24
};

ModelConfig configOf(const Shape& s)
{
  ModelConfig c;
  c.encoding.featuresPerLevel = s.F;
  c.encoding.levels = s.L;
  c.encoding.log2TableSize = s.log2T;
  c.encoding.baseResolution = s.base;
  c.encoding.finestResolution = s.finest;
  c.network.width = s.W;
  c.network.hiddenLayers = s.H;
  return c;
}

std::string name(const Shape& s)
{
  char b[128];
  std::snprintf(b, sizeof b, "F%d W%d H%d L%d T2^%d", s.F, s.W, s.H, s.L, s.log2T);
  return b;
}

/// A model with a table of O(0.1) values so that encodings and outputs are far from zero.
Model randomModel(const ModelConfig& c, uint64_t seed)
{
  Model m(c);
  m.initialize(seed);
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  for (size_t i = 0; i < m.encodingParamCount(); ++i)
    m.params()[i] = u(rng);
  for (size_t i = m.encodingParamCount(); i < m.paramCount(); ++i)
    m.params()[i] *= 2.0f;
  return m;
}

std::vector<float> randomPoints(int64_t n, uint64_t seed)
{
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> x(3 * n);
  for (float& v : x)
    v = u(rng);
  // A few points on the boundary.
  for (int k = 0; k < 3 && 3 * k + 2 < 3 * n; ++k)
  {
    x[3 * k] = k == 0 ? 0.0f : 1.0f;
    x[3 * k + 1] = k == 1 ? 0.0f : 1.0f;
    x[3 * k + 2] = 1.0f;
  }
  return x;
}

double relErr(const float* a, const float* b, size_t n)
{
  double num = 0, den = 0;
  for (size_t i = 0; i < n; ++i)
  {
    if (!std::isfinite(a[i]))
      return INFINITY;
    const double d = double(a[i]) - double(b[i]);
    num += d * d;
    den += double(b[i]) * b[i];
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

#define EXPECT_REL(err, tol, what)                                                                 \
  do                                                                                               \
  {                                                                                                \
    const double e_ = (err);                                                                       \
    std::printf("    %-40s rel err %.3e (tol %.0e)\n", (what).c_str(), e_, double(tol));           \
    if (!(e_ <= (tol)))                                                                            \
      nvtest::fail(__FILE__, __LINE__, (what) + ": relative error too large");                     \
  } while (0)

} // namespace

NV_TEST(encoding_matches_cpu)
{
  for (const Shape& s : kShapes)
  {
    const Model m = randomModel(configOf(s), 7);
    const int64_t n = 3000;
    const auto xyz = randomPoints(n, 11);
    const size_t D = size_t(s.L) * s.F;
    std::vector<float> cpu(n * D), gpu(n * D, NAN);
    CpuHashGrid::encode(m.layout(), m.params().data(), xyz.data(), n, cpu.data());
    gpu::testEncode(m, xyz.data(), n, gpu.data());
    EXPECT_REL(relErr(gpu.data(), cpu.data(), cpu.size()), kTolEncoding, "encoding " + name(s));
  }
}

NV_TEST(inference_matches_cpu)
{
  for (const Shape& s : kShapes)
  {
    const Model m = randomModel(configOf(s), 3);
    const int64_t n = 5001; // not a multiple of the tile
    const auto xyz = randomPoints(n, 5);
    std::vector<float> cpu(n), gpu(n, NAN);
    inferPoints(m, xyz.data(), n, cpu.data(), Device::Cpu);
    inferPoints(m, xyz.data(), n, gpu.data(), Device::Cuda);
    EXPECT_REL(relErr(gpu.data(), cpu.data(), n), kTolOutput, "MLP output " + name(s));
  }
}

NV_TEST(binned_inference_equals_unbinned)
{
  // Point arrays of 2^18 and more are sorted by Morton bin before the level-major encode and each output is written
  // to its point's original index: every output must be bit-identical to the unbinned path, for bins of several
  // sizes, a tail that is not a multiple of the tile, repeated points (one crowded bin), out-of-range and NaN
  // coordinates; and it must match the CPU engine.
  const Shape s = kShapes[2];
  const Model m = randomModel(configOf(s), 8);
  const int64_t n = (int64_t(1) << 18) + 77;
  auto xyz = randomPoints(n, 13);
  for (int64_t i = 0; i < 5000; ++i) // a crowded bin
  {
    xyz[3 * (1000 + i)] = 0.25f;
    xyz[3 * (1000 + i) + 1] = 0.5f;
    xyz[3 * (1000 + i) + 2] = 0.75f;
  }
  xyz[3 * 7] = -0.5f;
  xyz[3 * 8 + 1] = 1.5f;
  xyz[3 * 9 + 2] = NAN;
  std::vector<float> cpu(n), plain(n, NAN), binned(n, NAN);
  inferPoints(m, xyz.data(), n, cpu.data(), Device::Cpu);
  auto binnedSession = [&](int bits) {
    SessionOptions o;
    o.kernels = nvtest::kernelOptions();
    o.kernels.binBitsPerAxis = bits;
    return NetworkSession::create(Device::Cuda, m, o);
  };
  binnedSession(0)->inferPoints(xyz.data(), n, plain.data(), Memory::Host);
  EXPECT_TRUE(gpu::inferenceBinning(n, 0) == 0);
  EXPECT_TRUE(gpu::inferenceBinning((int64_t(1) << 18) - 1, -1) == 0); // automatic: none below 2^18 points
  for (int bits : { -1, 3, 7 })
  {
    binnedSession(bits)->inferPoints(xyz.data(), n, binned.data(), Memory::Host);
    EXPECT_TRUE(gpu::inferenceBinning(n, bits) == (bits < 0 ? 4 : bits)); // automatic: ~32 points per bin
    int64_t differ = 0;
    for (int64_t i = 0; i < n; ++i)
      differ += std::memcmp(&plain[i], &binned[i], sizeof(float)) == 0 ? 0 : 1;
    std::printf("    bits %d: %lld of %lld outputs differ from the unbinned path\n", bits, (long long)differ,
      (long long)n);
    EXPECT_TRUE(differ == 0);
  }
  // the NaN point is excluded from the CPU comparison (both engines are free to produce NaN there)
  cpu[9] = plain[9] = 0.0f;
  EXPECT_REL(relErr(plain.data(), cpu.data(), n), kTolOutput, std::string("binned inference vs CPU"));
}

NV_TEST(gradients_match_cpu)
{
  const float dummy[8] = {};
  VolumeView v;
  v.data = dummy;
  v.dims[0] = v.dims[1] = v.dims[2] = 2;
  for (const Shape& s : kShapes)
  {
    // L1 and L2, with the default float atomics and in deterministic mode (fixed-point sums)
    for (int variant = 0; variant < 4; ++variant)
    {
      const LossType loss = variant % 2 == 0 ? LossType::L1 : LossType::L2;
      const bool det = variant >= 2;
      const Model m = randomModel(configOf(s), 21);
      const int n = 3000;
      const auto xyz = randomPoints(n, 9);
      std::vector<float> cpuOut(n);
      inferPoints(m, xyz.data(), n, cpuOut.data(), Device::Cpu);
      std::mt19937 rng(5);
      std::normal_distribution<float> nd(0.0f, 0.3f);
      std::vector<float> targets(n);
      std::vector<uint8_t> valid(n, 1);
      for (int i = 0; i < n; ++i)
      {
        targets[i] = cpuOut[i] + nd(rng); // residuals of both signs, well away from 0
        if (i % 17 == 3)
          valid[i] = 0;
      }
      TrainConfig tc;
      tc.batchSize = n;
      tc.loss = loss;
      tc.deterministic = det;
      Model published = m;
      CpuTrainer cpu(m, v, TrainingPoints(), tc, [&published](const std::vector<float>& p) { published.params() = p; });
      std::vector<float> gc, gg;
      const float lc = cpu.lossAndGradient(xyz.data(), targets.data(), valid.data(), n, gc);
      const float lg = gpu::testLossAndGradient(m, tc, xyz.data(), targets.data(), valid.data(), n, gg,
        nvtest::kernelOptions());
      const std::string tag = name(s) + (loss == LossType::L1 ? " L1" : " L2") + (det ? " det" : "");
      EXPECT_REL(std::fabs(double(lg) - lc) / std::fabs(lc), kTolLoss, "loss " + tag);
      EXPECT_TRUE(gg.size() == gc.size());
      if (gg.size() != gc.size())
        continue;
      EXPECT_REL(relErr(gg.data(), gc.data(), m.encodingParamCount()), tolGrad(s.H), "table grad " + tag);
      for (int l = 0; l <= s.H; ++l)
      {
        const size_t off = m.layerOffset(l), cnt = size_t(m.layerInputs(l)) * m.layerOutputs(l);
        EXPECT_REL(relErr(gg.data() + off, gc.data() + off, cnt), tolGrad(s.H),
          "layer " + std::to_string(l) + " grad " + tag);
      }
    }
  }
}

NV_TEST(decode_equals_batched_inference)
{
  const Shape s = kShapes[2];
  const Model m = randomModel(configOf(s), 4);
  const int64_t grids[2][3] = { { 37, 19, 11 }, { 1, 5, 1 } };
  for (const auto& g : grids)
  {
    const int64_t nx = g[0], ny = g[1], nz = g[2], z0 = nz > 2 ? 2 : 0, z1 = nz;
    const int64_t n = nx * ny * (z1 - z0);
    std::vector<float> dec(n, NAN), inf(n, NAN), xyz(3 * n), cpu(n);
    decodeGridNormalized(m, nx, ny, nz, z0, z1, dec.data(), Device::Cuda);
    for (int64_t z = z0, i = 0; z < z1; ++z)
      for (int64_t y = 0; y < ny; ++y)
        for (int64_t x = 0; x < nx; ++x, ++i)
        {
          xyz[3 * i] = gridCoordinate(x, nx);
          xyz[3 * i + 1] = gridCoordinate(y, ny);
          xyz[3 * i + 2] = gridCoordinate(z, nz);
        }
    inferPoints(m, xyz.data(), n, inf.data(), Device::Cuda);
    decodeGridNormalized(m, nx, ny, nz, z0, z1, cpu.data(), Device::Cpu);
    int mismatches = 0;
    for (int64_t i = 0; i < n; ++i)
      mismatches += dec[i] == inf[i] ? 0 : 1;
    std::printf("    grid %lldx%lldx%lld: %d mismatches decode vs inference; rel err vs CPU decode %.3e\n",
      (long long)nx, (long long)ny, (long long)nz, mismatches, relErr(dec.data(), cpu.data(), n));
    EXPECT_TRUE(mismatches == 0);
    EXPECT_TRUE(relErr(dec.data(), cpu.data(), n) < kTolOutput);
  }
}

namespace
{
std::vector<float> testVolume(int n, bool withNaN)
{
  std::vector<float> v(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        v[(size_t(z) * n + y) * n + x] =
          float(std::sin(0.3 * x) * std::cos(0.2 * y) + 0.5 * std::sin(0.15 * z + 0.02 * x * y));
  if (withNaN)
    for (int y = 0; y < n / 2; ++y)
      for (int x = 0; x < n / 3; ++x)
        v[(size_t(n / 2) * n + y) * n + x] = NAN;
  return v;
}
/// The curve tests' model of the 40^3 test volume: 2^14 table, finest resolution 80, initialised with `seed`.
Model curveModel(const VolumeView& vol, uint64_t seed)
{
  ModelConfig c;
  c.encoding.log2TableSize = 14;
  c.encoding.finestResolution = 80;
  Model m = nvtest::untrainedModel(c, vol, seed);
  return m;
}
} // namespace

NV_TEST(training_curve_matches_cpu)
{
  const int n = 40;
  const auto data = testVolume(n, true);
  const VolumeView vol = floatCubeView(data, n);
  // Same seed, same curve. The loss is L2: with L1 at lr 1e-2 this small over-parameterised volume is chaotic
  // (each sample's gradient is the sign of its residual, and table entries that few samples touch move by about lr
  // per step whatever their gradient), so fp16 rounding and the order of float atomics alone move the final PSNR
  // of one GPU run by up to 5 dB between repeats of the same seed (seen on an H100; the CPU engine is
  // deterministic). The L1 accuracy bar is checked on real volumes by the benchmark (results/gpu_*.md).
  // With L2 the two engines follow the same curve up to fp16 rounding: measured on an H100 (3 repeats x 2 seeds)
  // at most 0.56 dB apart at any mark, in either direction, and the mean loss of steps 301-400 at most 22% apart
  // (1 dB of MSE is 26%). Tolerances: 1 dB per mark, 30% on the late loss. Step 100 lies on the steep early part of
  // the curve, where the two-pass kernels' run-to-run atomic noise moves the GPU's PSNR most: 0.6-1.1 dB from the CPU
  // over six runs (results/gpu_tests_2026-11-25c.md; once 1.09 dB); its bound is 1.5 dB.
  for (uint64_t seed : { 9, 10 })
  {
    const Model m = curveModel(vol, seed);
    TrainConfig tc;
    tc.batchSize = 16384;
    tc.seed = seed;
    tc.loss = LossType::L2;
    tc.optimizer.decayInterval = 100;
    tc.optimizer.decayFactor = 0.7;
    auto cpu = createTrainer(Device::Cpu, m, vol, tc);
    auto gpuT = createTrainer(Device::Cuda, m, vol, tc);
    EXPECT_TRUE(gpuT->device() == Device::Cuda);
    EXPECT_TRUE(gpuT->deviceMemoryBytes() > 0);
    double lc = 0, lg = 0;
    for (int i = 1; i <= 400; ++i)
    {
      const float a = cpu->step(), b = gpuT->step();
      if (i == 1)
        EXPECT_NEAR_REL(b, a, 1e-3, 1e-7); // same parameters, same batch: same loss before the first update
      if (i > 300)
      {
        lc += a;
        lg += b;
      }
      if (i % 100 == 0)
      {
        Model mc = m, mg = m;
        cpu->syncTo(mc);
        gpuT->syncTo(mg);
        const double pc = compareToSource(mc, vol, Device::Cpu).psnr;
        const double pg = compareToSource(mg, vol, Device::Cpu).psnr;
        std::printf("    seed %llu step %d: loss cpu %.6f gpu %.6f, PSNR cpu %.2f gpu %.2f dB\n",
          (unsigned long long)seed, i, a, b, pc, pg);
        EXPECT_TRUE(std::fabs(pc - pg) < (i == 100 ? 1.5 : 1.0));
      }
    }
    EXPECT_NEAR_REL(lg, lc, 0.30, 0.0); // mean loss of steps 301-400
  }
}

NV_TEST(host_sampled_equals_gpu_resident)
{
  const int n = 33;
  const auto data = testVolume(n, true);
  std::vector<int16_t> q(data.size());
  for (size_t i = 0; i < data.size(); ++i)
    q[i] = std::isfinite(data[i]) ? int16_t(std::lround(data[i] * 1000)) : int16_t(0);
  for (const ScalarType type : { ScalarType::Float32, ScalarType::Int16 })
  {
    VolumeView vol;
    vol.type = type;
    vol.data = type == ScalarType::Float32 ? static_cast<const void*>(data.data()) : q.data();
    vol.dims[0] = vol.dims[1] = vol.dims[2] = n;
    const VolumeStats st = computeStats(vol);
    vol.valueMin = st.min;
    vol.valueMax = st.max;
    ModelConfig c;
    c.encoding.log2TableSize = 12;
    c.encoding.finestResolution = 64;
    c.network.width = 32;
    c.network.hiddenLayers = 2;
    Model m(c);
    m.initialize(1);
    TrainConfig tc;
    tc.batchSize = 5000;
    tc.strategy = TrainingStrategy::GpuResident;
    auto a = createTrainer(Device::Cuda, m, vol, tc);
    auto a2 = createTrainer(Device::Cuda, m, vol, tc); // run-to-run noise of the GPU (fp16 atomics)
    tc.strategy = TrainingStrategy::HostSampled;
    auto b = createTrainer(Device::Cuda, m, vol, tc);
    double maxRel = 0, noise = 0, first = 0;
    for (int i = 0; i < 30; ++i)
    {
      const float la = a->step(), la2 = a2->step(), lb = b->step();
      const double rel = std::fabs(double(la) - lb) / std::max(1e-12, std::fabs(double(la)));
      if (i == 0)
        first = rel;
      maxRel = std::max(maxRel, rel);
      noise = std::max(noise, std::fabs(double(la) - la2) / std::max(1e-12, std::fabs(double(la))));
    }
    std::printf("    %s: relative loss difference host-sampled vs GPU-resident: step 1 %.3e, max over 30 steps "
                "%.3e (GPU-resident twice: %.3e)\n",
      scalarTypeName(type), first, maxRel, noise);
    // Step 1 sees the same parameters and (if the host samples the same targets) the same batch: equal losses.
    // Later steps drift apart by the order of the fp16 gradient atomics, as two GPU-resident runs do.
    EXPECT_TRUE(first < 1e-5);
    EXPECT_TRUE(maxRel < 0.05);
    EXPECT_TRUE(a->stepsDone() == 30 && b->stepsDone() == 30);
  }
}

NV_TEST(queued_steps_equal_single_steps)
{
  // Trainer::steps queues many steps (a ring of 256 counter slots, the L2 loss-gradient scale computed on the
  // device from the previous slot) and must follow the same curve as step() called one at a time.
  const int n = 24;
  const auto data = testVolume(n, false);
  const VolumeView vol = floatCubeView(data, n);
  ModelConfig c;
  c.encoding.log2TableSize = 12;
  c.encoding.finestResolution = 48;
  c.network.width = 32;
  c.network.hiddenLayers = 2;
  Model m(c);
  m.initialize(3);
  for (const LossType loss : { LossType::L2, LossType::L1 })
  {
    TrainConfig tc;
    tc.batchSize = 4096;
    tc.loss = loss;
    auto a = createTrainer(Device::Cuda, m, vol, tc);
    auto b = createTrainer(Device::Cuda, m, vol, tc);
    const int k = 300; // wraps the 256-slot ring
    std::vector<float> la(k), lb(k);
    a->steps(k, la.data());
    for (int i = 0; i < k; ++i)
      lb[i] = b->step();
    double late = 0, lateA = 0;
    for (int i = k - 50; i < k; ++i)
    {
      late += lb[i];
      lateA += la[i];
    }
    std::printf("    %s: step 1 loss %.6g / %.6g, mean loss of the last 50 steps %.6g queued / %.6g single\n",
      loss == LossType::L2 ? "L2" : "L1", la[0], lb[0], lateA / 50, late / 50);
    EXPECT_TRUE(a->stepsDone() == k && b->stepsDone() == k);
    EXPECT_NEAR_REL(la[0], lb[0], 1e-6, 0.0);
    EXPECT_TRUE(std::isfinite(lateA) && lateA < 0.5 * 50 * la[0]); // it trains
    EXPECT_NEAR_REL(lateA, late, 0.05, 0.0);
  }
}

NV_TEST(deterministic_training_is_bitwise_repeatable)
{
  // TrainConfig::deterministic sums the gradients in 64-bit fixed point: two runs of a seed give the same
  // parameters bit for bit (GPU-resident and host-sampled, L1 and L2, queued and single steps; the kernel variant
  // from the command line, e.g. --two-pass=1 or --wmma). The default float atomics give runs that differ, which is
  // what makes this test able to fail; that difference is printed, not asserted. Deterministic training must also
  // train as well as the default (L2: late loss within 30%, the tolerance of training_curve_matches_cpu).
  const int n = 40;
  const auto data = testVolume(n, true);
  const VolumeView vol = floatCubeView(data, n);
  const Model m = curveModel(vol, 4);
  for (const TrainingStrategy strategy : { TrainingStrategy::GpuResident, TrainingStrategy::HostSampled })
  {
    for (const LossType loss : { LossType::L1, LossType::L2 })
    {
      auto run = [&](bool det, std::vector<float>& losses) {
        TrainConfig tc;
        tc.batchSize = 16384;
        tc.seed = 12;
        tc.loss = loss;
        tc.strategy = strategy;
        tc.deterministic = det;
        auto t = createTrainer(Device::Cuda, m, vol, tc);
        losses.assign(300, 0.0f);
        t->steps(270, losses.data()); // queued (wraps no ring: < 256 + 14 single steps below)
        for (int i = 270; i < 300; ++i)
          losses[i] = t->step();
        Model out = m;
        t->syncTo(out);
        return out;
      };
      std::vector<float> l1, l2, l3, l4;
      const Model a = run(true, l1), b = run(true, l2);
      const Model x = run(false, l3), y = run(false, l4);
      size_t differ = 0, differDefault = 0;
      for (size_t i = 0; i < a.paramCount(); ++i)
      {
        differ += std::memcmp(&a.params()[i], &b.params()[i], sizeof(float)) != 0 ? 1 : 0;
        differDefault += std::memcmp(&x.params()[i], &y.params()[i], sizeof(float)) != 0 ? 1 : 0;
      }
      bool lossesEqual = std::memcmp(l1.data(), l2.data(), l1.size() * sizeof(float)) == 0;
      double lateDet = 0, lateDefault = 0;
      for (int i = 250; i < 300; ++i)
      {
        lateDet += l1[i];
        lateDefault += l3[i];
      }
      const double pa = compareToSource(a, vol, Device::Cpu).psnr, px = compareToSource(x, vol, Device::Cpu).psnr;
      std::printf("    %s %s: deterministic twice: %zu of %zu parameters differ, losses %s; default twice: %zu "
                  "differ; late loss %.6g det / %.6g default; PSNR %.2f det / %.2f default dB\n",
        strategy == TrainingStrategy::GpuResident ? "GPU-resident" : "host-sampled",
        loss == LossType::L1 ? "L1" : "L2", differ, a.paramCount(), lossesEqual ? "equal" : "DIFFER", differDefault,
        lateDet / 50, lateDefault / 50, pa, px);
      EXPECT_TRUE(differ == 0);
      EXPECT_TRUE(lossesEqual);
      EXPECT_TRUE(std::isfinite(lateDet) && lateDet < 0.5 * 50 * l1[0]); // it trains
      // As well as the default: with L2 (L1 on this small volume is chaotic, see training_curve_matches_cpu: one
      // run of the default moves by up to 5 dB, measured here 33.3-37.2 dB; real volumes are in the benchmark).
      if (loss == LossType::L2)
        EXPECT_NEAR_REL(lateDet, lateDefault, 0.30, 0.0);
    }
  }
}

NV_TEST(bank_training_matches_cpu)
{
  // Training from a bank of points (Probe sampling, sparse OpenVDB grids): the GPU gathers the same bank entries
  // as the CPU for each sample (randomBankIndex), so the first losses agree to rounding and the curves follow each
  // other within the tolerances of training_curve_matches_cpu (L2: 1 dB per mark); deterministic mode repeats bit
  // for bit. The bank: trilinear samples of the 40^3 test volume at random points, 1 in 13 NaN (never trained on).
  const int n = 40;
  const auto data = testVolume(n, true);
  const VolumeView vol = floatCubeView(data, n);
  const int64_t count = int64_t(1) << 18;
  std::vector<float> xyz(static_cast<size_t>(3 * count)), values(static_cast<size_t>(count));
  std::vector<uint8_t> ok(static_cast<size_t>(count));
  for (int64_t i = 0; i < count; ++i)
    randomPoint(77, 0, uint64_t(i), &xyz[size_t(3 * i)]);
  sampleTargets(vol, xyz.data(), count, values.data(), ok.data());
  for (int64_t i = 0; i < count; ++i)
    if (!ok[size_t(i)] || i % 13 == 0)
      values[size_t(i)] = NAN;
  TrainingPoints bank;
  bank.xyz = xyz.data();
  bank.values = values.data();
  bank.count = count;
  const Model m = curveModel(vol, 3);
  TrainConfig tc;
  tc.batchSize = 16384;
  tc.seed = 5;
  tc.loss = LossType::L2;
  tc.optimizer.decayInterval = 100;
  tc.optimizer.decayFactor = 0.7;
  auto cpu = createTrainer(Device::Cpu, m, bank, tc);
  auto gpuT = createTrainer(Device::Cuda, m, bank, tc);
  EXPECT_TRUE(gpuT->deviceMemoryBytes() >= int64_t(16 * count));
  for (int i = 1; i <= 300; ++i)
  {
    const float a = cpu->step(), b = gpuT->step();
    EXPECT_TRUE(std::isfinite(a) && std::isfinite(b));
    if (i == 1)
      EXPECT_NEAR_REL(b, a, 1e-3, 1e-7); // same parameters, same bank entries: same loss before the first update
    if (i % 100 == 0)
    {
      Model mc = m, mg = m;
      cpu->syncTo(mc);
      gpuT->syncTo(mg);
      const double pc = compareToSource(mc, vol, Device::Cpu).psnr, pg = compareToSource(mg, vol, Device::Cpu).psnr;
      std::printf("    bank step %d: loss cpu %.6f gpu %.6f, PSNR cpu %.2f gpu %.2f dB\n", i, a, b, pc, pg);
      EXPECT_TRUE(std::fabs(pc - pg) < 1.0);
      if (i == 300)
        EXPECT_TRUE(pg > 30.0);
    }
  }
  tc.deterministic = true;
  auto run = [&]() {
    auto t = createTrainer(Device::Cuda, m, bank, tc);
    t->steps(120, nullptr);
    Model out = m;
    t->syncTo(out);
    return out;
  };
  const Model a = run(), b = run();
  EXPECT_TRUE(std::memcmp(a.params().data(), b.params().data(), a.paramCount() * sizeof(float)) == 0);
}

NV_TEST(batch_source_training_matches_cpu)
{
  // Out-of-core batches (Core/BatchSource.h): the host draws each step's positions and targets, the CUDA trainer
  // copies both. Fed what the volume trainer draws (MirrorBatchSource), the GPU follows the CPU trainer on the same
  // source as training_curve_matches_cpu does (same first loss; L2, 1 dB per mark, 1.5 at step 100).
  const int n = 40;
  const auto data = testVolume(n, true);
  const VolumeView vol = floatCubeView(data, n);
  const Model m = curveModel(vol, 4);
  TrainConfig tc;
  tc.batchSize = 16384;
  tc.seed = 6;
  tc.loss = LossType::L2;
  tc.optimizer.decayInterval = 100;
  tc.optimizer.decayFactor = 0.7;
  nvtest::MirrorBatchSource cpuSource(vol), gpuSource(vol);
  auto cpuSession = nvtest::session(m, Device::Cpu), gpuSession = nvtest::session(m, Device::Cuda);
  auto cpu = cpuSession->createTrainer(cpuSource, tc);
  auto gpuT = gpuSession->createTrainer(gpuSource, tc);
  EXPECT_TRUE(gpuT->device() == Device::Cuda);
  for (int i = 1; i <= 300; ++i)
  {
    const float a = cpu->step(), b = gpuT->step();
    EXPECT_TRUE(std::isfinite(a) && std::isfinite(b));
    if (i == 1)
      EXPECT_NEAR_REL(b, a, 1e-3, 1e-7); // same parameters, same batch: same loss before the first update
    if (i % 100 == 0)
    {
      Model mc = m, mg = m;
      cpu->syncTo(mc);
      gpuT->syncTo(mg);
      const double pc = compareToSource(mc, vol, Device::Cpu).psnr, pg = compareToSource(mg, vol, Device::Cpu).psnr;
      std::printf("    batch source step %d: loss cpu %.6f gpu %.6f, PSNR cpu %.2f gpu %.2f dB\n", i, a, b, pc, pg);
      EXPECT_TRUE(std::fabs(pc - pg) < (i == 100 ? 1.5 : 1.0));
    }
  }
  // The source is asked before each step's batch (the GPU's next batch is drawn while the current one trains).
  EXPECT_TRUE(gpuSource.Prepared >= 300);
}

NV_TEST(importance_training_matches_cpu)
{
  // TrainConfig::importanceGrid: the GPU draws from the same integer CDF as the CPU (Core/ImportanceGrid.h). Until
  // the first refresh the points are the uniform ones (first loss equal to the CPU's); afterwards the two engines
  // follow the same L2 curve (1 dB, as training_curve_matches_cpu) and deterministic mode repeats bit for bit.
  const int n = 40;
  const auto data = testVolume(n, true);
  const VolumeView vol = floatCubeView(data, n);
  const Model m = curveModel(vol, 9);
  TrainConfig tc;
  tc.batchSize = 16384;
  tc.seed = 9;
  tc.loss = LossType::L2;
  tc.importanceGrid = 8;
  auto cpu = createTrainer(Device::Cpu, m, vol, tc);
  auto gpuT = createTrainer(Device::Cuda, m, vol, tc);
  for (int i = 1; i <= 300; ++i)
  {
    const float a = cpu->step(), b = gpuT->step();
    if (i == 1)
      EXPECT_NEAR_REL(b, a, 1e-3, 1e-7);
  }
  Model mc = m, mg = m;
  cpu->syncTo(mc);
  gpuT->syncTo(mg);
  const double pc = compareToSource(mc, vol, Device::Cpu).psnr, pg = compareToSource(mg, vol, Device::Cpu).psnr;
  std::printf("    importance 8^3, 300 steps: PSNR cpu %.2f gpu %.2f dB\n", pc, pg);
  EXPECT_TRUE(std::fabs(pc - pg) < 1.0);
  tc.deterministic = true;
  auto run = [&]() {
    auto t = createTrainer(Device::Cuda, m, vol, tc);
    t->steps(100, nullptr);
    Model out = m;
    t->syncTo(out);
    return out;
  };
  const Model a = run(), b = run();
  EXPECT_TRUE(std::memcmp(a.params().data(), b.params().data(), a.paramCount() * sizeof(float)) == 0);
}

int main(int argc, char** argv)
{
  // Kernel variants (e.g. --two-pass=1, --wmma) apply to every session the test creates.
  nvtest::kernelOptions() = nvbench::parseKernelFlags(argc, argv);
  std::string why;
  if (!gpu::deviceUsable(&why))
  {
    std::printf("SKIPPED: no usable GPU (%s)\n", why.c_str());
    return kSkip;
  }
  std::printf("GPU: %s\n", gpu::deviceDescription().c_str());
  return nvtest::runCases(argc, argv);
}
