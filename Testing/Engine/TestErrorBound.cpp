// The error-bounded mode (Core/ErrorCorrections.h): a trained network's decoded field meets the bound at every
// sample once its corrections are applied (fp16 and 8-bit storage, after a file round trip, by every decode of the
// source grid: decodeGridValues in float and double, slab by slab, and the CPU renderer's decoded grid); the list's
// coding round trips and hostile lists are refused; absurd bounds are refused; a published training step drops
// the corrections of the parameters it replaced; models without the mode keep their format version.
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/ErrorCorrections.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"
#include "RenderFixtures.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

using namespace nv;

namespace
{
constexpr int kN = 32;

/// A smooth field with a sharp ball and seeded noise: a short training leaves errors well above 1% of the range.
const std::vector<float>& field()
{
  static const std::vector<float> f = [] {
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 1.5);
    std::vector<float> v = nvtest::sampledCube(kN, [&](double X, double Y, double Z) {
      const double r2 = (X - .4) * (X - .4) + (Y - .55) * (Y - .55) + (Z - .5) * (Z - .5);
      return 50.0 * std::sin(5 * X) * std::cos(4 * Y) + 30.0 * std::sin(6 * Z) + (r2 < 0.06 ? 40.0 : 0.0);
    });
    for (float& x : v)
      x += static_cast<float>(noise(rng));
    return v;
  }();
  return f;
}

/// The network trained 150 steps on field(), stored in `storage`.
Model trained(Precision storage)
{
  const VolumeView vol = nvtest::cubeView(field(), kN);
  Model m = nvtest::untrainedModel(nvtest::smallModelConfig(12), vol, 3);
  for (int a = 0; a < 3; ++a)
  {
    m.source.dims[a] = kN;
    m.source.bounds[2 * a + 1] = kN - 1;
  }
  m.source.rawBytes = int64_t(kN) * kN * kN * 4;
  TrainConfig tc;
  tc.batchSize = 8192;
  tc.seed = 3;
  tc.threads = 2;
  auto tr = nvtest::createTrainer(Device::Cpu, m, vol, tc);
  tr->steps(150, nullptr);
  tr->syncTo(m);
  m.quantize(storage);
  return m;
}

/// The corrections of `m` for `bound`, as the filter computes them: the session's decode (double), slab by slab.
ErrorCorrections corrections(const Model& m, double bound)
{
  const VolumeView vol = nvtest::cubeView(field(), kN);
  auto s = nvtest::session(m, Device::Cpu, 2);
  ErrorCorrections c;
  c.bound = bound;
  const int64_t slice = int64_t(kN) * kN;
  std::vector<double> decoded(size_t(slice * 5));
  for (int64_t z0 = 0; z0 < kN; z0 += 5)
  {
    const int64_t z1 = std::min<int64_t>(kN, z0 + 5);
    decodeGridValues(*s, kN, kN, kN, z0, z1, decoded.data());
    appendCorrections(c, decoded.data(), vol, z0 * slice, (z1 - z0) * slice);
  }
  return c;
}

/// The largest |decoded - source| over every sample of the source grid, decoded by `m`'s session in float (slabs
/// of 7 slices) and in double (the whole grid); the larger of the two.
double maxError(const Model& m)
{
  auto s = nvtest::session(m, Device::Cpu, 2);
  const int64_t count = int64_t(kN) * kN * kN, slice = int64_t(kN) * kN;
  std::vector<float> f(static_cast<size_t>(count));
  for (int64_t z0 = 0; z0 < kN; z0 += 7)
    decodeGridValues(*s, kN, kN, kN, z0, std::min<int64_t>(kN, z0 + 7), f.data() + z0 * slice);
  std::vector<double> d(static_cast<size_t>(count));
  decodeGridValues(*s, kN, kN, kN, 0, kN, d.data());
  double worst = 0.0;
  for (int64_t i = 0; i < count; ++i)
  {
    const double src = field()[size_t(i)];
    const double e = std::max(std::fabs(double(f[size_t(i)]) - src), std::fabs(d[size_t(i)] - src));
    worst = std::isnan(e) ? std::numeric_limits<double>::infinity() : std::max(worst, e);
  }
  return worst;
}

template <typename F>
void expectError(F&& f, const std::string& message, const char* what)
{
  try
  {
    f();
  }
  catch (const Error& e)
  {
    if (std::string(e.what()).find(message) == std::string::npos)
      nvtest::fail(__FILE__, __LINE__, std::string(what) + ": unexpected message: " + e.what());
    return;
  }
  nvtest::fail(__FILE__, __LINE__, std::string(what) + ": no error");
}
} // namespace

NV_TEST(decoded_field_meets_the_bound_at_every_sample)
{
  for (Precision storage : { Precision::Float16, Precision::Quantized8 })
  {
    Model m = trained(storage);
    const double range = m.source.valueMax - m.source.valueMin;
    const double unbounded = maxError(m);
    for (double fraction : { 0.02, 0.005 })
    {
      const double bound = fraction * range;
      Model b = m;
      b.corrections = corrections(m, bound);
      const double bounded = maxError(b);
      // Through the file: version 5, the same corrections, the same bound met.
      const std::vector<uint8_t> bytes = serialize(b);
      uint32_t version = 0;
      std::memcpy(&version, bytes.data() + 8, 4);
      const Model back = deserialize(bytes);
      const double fileBound = maxError(back);
      std::printf("  %s, bound %.4g (%.3g of the range): %lld corrections, %lld bytes (%.2f per correction), "
                  "ratio %.1f -> %.1f; max error %.4g -> %.4g (file %.4g)\n",
        precisionName(storage), bound, fraction, (long long)b.corrections.count(),
        (long long)b.corrections.storedBytes(), double(b.corrections.codedBytes()) / double(b.corrections.count()),
        double(m.source.rawBytes) / double(m.storedBytes()), double(b.source.rawBytes) / double(b.storedBytes()),
        unbounded, bounded, fileBound);
      EXPECT_TRUE(unbounded > 2.0 * bound); // the network alone misses the bound: corrections were needed
      EXPECT_TRUE(b.corrections.count() > 0);
      EXPECT_TRUE(bounded <= bound);
      EXPECT_TRUE(fileBound <= bound);
      EXPECT_TRUE(version == kFormatVersionCorrections);
      EXPECT_TRUE(back.corrections.bound == bound && back.corrections.index == b.corrections.index &&
        back.corrections.steps == b.corrections.steps && back.storagePrecision() == storage);
      EXPECT_TRUE(b.storedBytes() == m.storedBytes() + b.corrections.storedBytes());
      EXPECT_TRUE(serialize(back) == bytes); // the same bytes again
    }
  }
}

NV_TEST(cpu_renderer_decoded_grid_applies_the_corrections)
{
  // The Decode path's grid of the source's dims is the corrected field: rendered with the corrections it differs
  // from the network's own picture, and matches a render of the corrected field given as a grid.
  Model m = trained(Precision::Float16);
  Model b = m;
  b.corrections = corrections(m, 0.005 * (m.source.valueMax - m.source.valueMin));
  RenderRequest q = nvtest::blobRequest(m, RenderPath::Decode, ShadingMode::RayMarch, 48, 48);
  q.waitForDecode = true;
  auto render = [&](const Model& model, const VolumeView* grid) {
    auto s = nvtest::session(model, Device::Cpu, 2);
    RenderRequest r = q;
    r.grid = grid;
    RenderResult out;
    s->render(r, out, Memory::Host);
    return out.rgba;
  };
  const std::vector<float> plain = render(m, nullptr), corrected = render(b, nullptr);
  // The corrected field, decoded by decodeGridValues, as the grid to march.
  std::vector<float> grid(size_t(kN) * kN * kN);
  auto s = nvtest::session(b, Device::Cpu, 2);
  decodeGridValues(*s, kN, kN, kN, 0, kN, grid.data());
  VolumeView gv = nvtest::cubeView(grid, kN);
  gv.valueMin = b.source.valueMin;
  gv.valueMax = b.source.valueMax;
  const std::vector<float> reference = render(m, &gv);
  double differs = 0.0, matches = 0.0;
  for (size_t i = 0; i < plain.size(); ++i)
  {
    differs = std::max(differs, double(std::fabs(plain[i] - corrected[i])));
    matches = std::max(matches, double(std::fabs(reference[i] - corrected[i])));
  }
  std::printf("  decode path: max |plain - corrected| %.3g, max |grid - corrected| %.3g\n", differs, matches);
  EXPECT_TRUE(!plain.empty() && plain.size() == corrected.size() && reference.size() == corrected.size());
  EXPECT_TRUE(differs > 1e-3);
  EXPECT_TRUE(matches < 1e-5);
}

NV_TEST(a_decode_render_before_decoding_corrects_once)
{
  // The GUI race of issue 25 (a summary with the network's own PSNR beside its corrections): the Decode path rendered
  // the session's corrected grid of the source's dims, then the filter's measurement decoded the source grid; the
  // session copied the renderer's grid (already corrected) and decodeGridValues corrected it again. Decoding after
  // such a render must give the values of a session that never rendered.
  Model m = trained(Precision::Float16);
  const double bound = 0.005 * (m.source.valueMax - m.source.valueMin);
  m.corrections = corrections(m, bound);
  RenderRequest q = nvtest::blobRequest(m, RenderPath::Decode, ShadingMode::RayMarch, 32, 32);
  q.waitForDecode = true;
  for (int a = 0; a < 3; ++a)
    q.decodeResolution[a] = kN; // the source's own grid: the renderer's grid is the corrected field
  auto rendered = nvtest::session(m, Device::Cpu, 2);
  RenderResult out;
  rendered->render(q, out, Memory::Host);
  auto fresh = nvtest::session(m, Device::Cpu, 2);
  const int64_t count = int64_t(kN) * kN * kN;
  std::vector<double> afterRender(static_cast<size_t>(count)), plain(static_cast<size_t>(count));
  decodeGridValues(*rendered, kN, kN, kN, 0, kN, afterRender.data());
  decodeGridValues(*fresh, kN, kN, kN, 0, kN, plain.data());
  double worst = 0.0, apart = 0.0;
  for (int64_t i = 0; i < count; ++i)
  {
    worst = std::max(worst, std::fabs(afterRender[size_t(i)] - double(field()[size_t(i)])));
    apart = std::max(apart, std::fabs(afterRender[size_t(i)] - plain[size_t(i)]));
  }
  const ErrorStats measured = compareToSource(*rendered, nvtest::cubeView(field(), kN));
  std::printf("  after a Decode render: max error %.4g (bound %.4g), %.3g from a fresh session's decode, "
              "PSNR %.2f dB, max error measured %.4g\n", worst, bound, apart, measured.psnr, measured.maxAbsError);
  EXPECT_TRUE(!out.rgba.empty());
  EXPECT_TRUE(worst <= bound);
  EXPECT_TRUE(apart < 1e-3 * bound);
  EXPECT_TRUE(measured.maxAbsError <= bound);
}

NV_TEST(absurd_bounds_are_refused)
{
  const Model m = trained(Precision::Float16);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (double bad : { -1.0, nan, inf, -inf })
  {
    expectError([&] { validateErrorBound(bad); }, "MaxError", "a bad bound");
    expectError([&] { corrections(m, bad); }, "MaxError", "corrections for a bad bound");
    Model b = m;
    b.corrections.bound = bad;
    expectError([&] { serialize(b); }, "MaxError", "serializing a bad bound");
  }
  expectError([&] { corrections(m, 0.0); }, "bound > 0", "corrections for a zero bound");
  // A bound far below the network's error: the corrections would not fit 32 bits.
  expectError([&] { corrections(m, 1e-300); }, "too small", "a bound too small to code");
  // A huge bound: the mode is on, nothing needs a correction, the file says so and costs 40 bytes.
  Model huge = m;
  huge.corrections = corrections(m, 1e300);
  EXPECT_TRUE(huge.corrections.enabled() && huge.corrections.count() == 0);
  EXPECT_TRUE(huge.storedBytes() == m.storedBytes() + 40); // bound, count, size, two empty streams
  const Model back = deserialize(serialize(huge));
  EXPECT_TRUE(back.corrections.bound == 1e300 && back.corrections.count() == 0);
  // Off (0): no corrections, and the version of the same model without the mode.
  uint32_t version = 0;
  const std::vector<uint8_t> plain = serialize(m);
  std::memcpy(&version, plain.data() + 8, 4);
  EXPECT_TRUE(version == kFormatVersionNoMask && !deserialize(plain).corrections.enabled());
}

NV_TEST(coded_lists_round_trip_and_hostile_ones_are_refused)
{
  ErrorCorrections c;
  c.bound = 0.5;
  c.index = { 0, 1, 200, 70000, (int64_t(1) << 33) + 5 };
  c.steps = { 1, -1, 64, -2147483647 - 1, 2147483647 };
  const int64_t samples = (int64_t(1) << 33) + 6;
  const std::vector<uint8_t> bytes = encodeCorrections(c);
  EXPECT_TRUE(int64_t(bytes.size()) == c.codedBytes());
  const ErrorCorrections back = decodeCorrections(bytes.data(), bytes.size(), c.index.size(), samples, 0.5);
  EXPECT_TRUE(back.index == c.index && back.steps == c.steps);
  // One sample fewer: the last index is outside the grid.
  expectError([&] { inspectCorrections(bytes.data(), bytes.size(), c.index.size(), samples - 1); }, "steps",
    "an index past the grid");
  expectError([&] { inspectCorrections(bytes.data(), bytes.size() - 1, c.index.size(), samples); }, "",
    "a truncated list");
  expectError([&] { inspectCorrections(bytes.data(), bytes.size(), c.index.size() - 1, samples); }, "takes",
    "a count below the list's");
  expectError([&] { inspectCorrections(bytes.data(), bytes.size(), uint64_t(samples) + 1, samples); }, "corrections on",
    "more corrections than samples");
  const std::vector<uint8_t> repeated = packCorrectionStreams({ 1, 0 }, { 2, 2 }); // index 0, then 0 samples on
  expectError([&] { inspectCorrections(repeated.data(), repeated.size(), 2, 10); }, "steps 0 samples", "a repeated index");
  const std::vector<uint8_t> zero = packCorrectionStreams({ 1 }, { 0 }); // a correction of 0 steps
  expectError([&] { inspectCorrections(zero.data(), zero.size(), 1, 10); }, "non-zero", "a zero correction");
  const std::vector<uint8_t> wide = packCorrectionStreams({ 1 }, { 0xFF, 0xFF, 0xFF, 0xFF, 0x7F }); // 2^35 - 1
  expectError([&] { inspectCorrections(wide.data(), wide.size(), 1, 10); }, "within 32 bits", "beyond 32 bits");
  const std::vector<uint8_t> long_ = packCorrectionStreams(std::vector<uint8_t>(11, 1), { 2 }); // 11 index bytes
  expectError([&] { inspectCorrections(long_.data(), long_.size(), 1, 100); }, "at most 10", "an overlong stream");
  expectError([&] { inspectCorrections(zero.data(), zero.size() + 3, 1, 10); }, "", "trailing bytes");
  // A crafted version-5 file: a correction list whose count disagrees with its bytes, checksum fixed.
  Model m = trained(Precision::Float16);
  m.corrections = corrections(m, 0.005 * (m.source.valueMax - m.source.valueMin));
  std::vector<uint8_t> file = serialize(m);
  const size_t listBytesAt = file.size() - 4 - size_t(m.corrections.codedBytes()) - 8;
  uint64_t count = 0;
  std::memcpy(&count, file.data() + listBytesAt - 8, 8);
  EXPECT_TRUE(count == uint64_t(m.corrections.count()));
  ++count;
  std::memcpy(file.data() + listBytesAt - 8, &count, 8);
  const uint32_t crc = crc32(file.data(), file.size() - 4);
  std::memcpy(file.data() + file.size() - 4, &crc, 4);
  expectError([&] { deserialize(file); }, "corrupt NeuralVolume model: error corrections", "a crafted count");
  double badBound = -1.0;
  std::memcpy(file.data() + listBytesAt - 16, &badBound, 8);
  const uint32_t crc2 = crc32(file.data(), file.size() - 4);
  std::memcpy(file.data() + file.size() - 4, &crc2, 4);
  expectError([&] { deserialize(file); }, "error bound of", "a crafted negative bound");
}

NV_TEST(a_published_step_drops_the_corrections)
{
  Model m = trained(Precision::Float32);
  m.corrections = corrections(m, 0.005 * (m.source.valueMax - m.source.valueMin));
  const VolumeView vol = nvtest::cubeView(field(), kN);
  auto s = nvtest::session(m, Device::Cpu, 2);
  EXPECT_TRUE(s->errorCorrections() && s->errorCorrections()->count() == m.corrections.count());
  TrainConfig tc;
  tc.batchSize = 1024;
  tc.threads = 2;
  auto t = s->createTrainer(vol, tc);
  t->step();
  EXPECT_TRUE(s->errorCorrections() != nullptr); // not published yet
  t->publish();
  EXPECT_TRUE(s->errorCorrections() == nullptr && !s->currentModel().corrections.enabled());
  s->setModel(m);
  EXPECT_TRUE(s->errorCorrections() != nullptr);
}

NV_TEST_MAIN()
