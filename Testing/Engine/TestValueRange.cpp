// The value normalisation (Core/ValueRange.h): bit-identical to the plain formulas for ordinary ranges; finite and
// exact to rounding for a range wider than the largest double (max - min = inf), through training, decoding, the
// error figures, the network file and rendering.
#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "Core/RenderSetup.h"
#include "Core/Serialization.h"
#include "Core/ValueRange.h"
#include "RenderFixtures.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <cfloat>
#include <cmath>
#include <cstring>
#include <vector>

using namespace nv;

namespace
{
bool same(double a, double b)
{
  return std::memcmp(&a, &b, sizeof(double)) == 0;
}

/// 2^1023: +-1.5 scaled by it spans +-1.348e308, a width of 2.7e308 > DBL_MAX (an exact scaling).
const double kHuge = std::ldexp(1.0, 1023);

/// A smooth float64 n^3 field in [-1.5, 1.5] times `scale`.
std::vector<double> field(int n, double scale)
{
  std::vector<double> v(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
      {
        const double X = double(x) / (n - 1), Y = double(y) / (n - 1), Z = double(z) / (n - 1);
        const double f = std::sin(5 * X) * std::cos(4 * Y) + 0.5 * std::sin(6 * Z);
        v[(size_t(z) * n + y) * n + x] = f * scale; // |f| <= 1.5
      }
  return v;
}

Model trainOn(const VolumeView& vol, int steps)
{
  Model m = nvtest::untrainedModel(nvtest::smallModelConfig(14), vol, 5);
  for (int a = 0; a < 3; ++a)
    m.source.dims[a] = vol.dims[a];
  TrainConfig tc;
  tc.batchSize = 8192;
  tc.seed = 5;
  tc.threads = 2;
  auto tr = nvtest::createTrainer(Device::Cpu, m, vol, tc);
  tr->steps(steps, nullptr);
  tr->syncTo(m);
  return m;
}
} // namespace

NV_TEST(ordinary_ranges_are_the_plain_formulas_bit_for_bit)
{
  const double ranges[][2] = { { 0.0, 1.0 }, { -3.25, 7.5 }, { 1e6, 1e6 + 1e-7 }, { -1e300, 1e300 },
    { 1e-300, 3e-300 }, { -8.5e307, 8.5e307 }, { 0.0, DBL_MAX }, { -DBL_MAX, 0.0 }, { 1e-320, 3e-320 } };
  for (const auto& r : ranges)
  {
    const double lo = r[0], hi = r[1], w = hi - lo, inv = w > 0.0 ? 1.0 / w : 0.0;
    const ValueRange range(lo, hi);
    EXPECT_TRUE(!range.halved() && range.spans() && same(range.width(), w));
    for (double t : { -0.25, 0.0, 0.1, 0.333, 0.5, 0.9999, 1.0, 1.5 })
    {
      const double v = lo + t * w;
      EXPECT_TRUE(same(range.normalize(v), (v - lo) * inv));
      EXPECT_TRUE(same(range.fraction(v), (v - lo) / w));
      const double plain = lo + t * w; // beyond the doubles (t outside [0, 1] at their ends) it saturates
      EXPECT_TRUE(same(range.denormalize(t), std::isfinite(plain) ? plain : plain > 0 ? DBL_MAX : -DBL_MAX));
      EXPECT_TRUE(same(range.span(t), t * w));
      EXPECT_TRUE(same(range.perWidth(t), t / w));
    }
  }
  // A constant field: normalised to 0, de-normalised to its value.
  // De-normalised values beyond the largest double saturate (a network's output slightly outside [0, 1]).
  const ValueRange top(-DBL_MAX, -1e304);
  EXPECT_TRUE(!top.halved() && top.denormalize(-0.01) == -DBL_MAX && top.denormalize(0.0) == -DBL_MAX);
  EXPECT_TRUE(std::isfinite(top.denormalize(1.01)) && top.denormalize(1.01) > -1e304);
  const ValueRange c(42.5, 42.5);
  EXPECT_TRUE(!c.spans() && !c.halved() && c.width() == 0.0);
  EXPECT_TRUE(c.normalize(42.5) == 0.0 && c.fraction(42.5) == 0.0 && c.denormalize(0.7) == 42.5);
}

NV_TEST(a_range_wider_than_the_largest_double_is_finite)
{
  const double lo = -1.5e308, hi = 1.5e308;
  EXPECT_TRUE(std::isinf(hi - lo)); // the plain formula: inf width, NaN or 0 everywhere
  const ValueRange r(lo, hi);
  EXPECT_TRUE(r.halved() && r.spans() && std::isinf(r.width()));
  EXPECT_TRUE(r.normalize(lo) == 0.0 && r.normalize(hi) == 1.0 && r.normalize(0.0) == 0.5);
  EXPECT_TRUE(r.fraction(lo) == 0.0 && r.fraction(hi) == 1.0 && r.fraction(7.5e307) == 0.75);
  EXPECT_TRUE(r.denormalize(0.0) == lo && r.denormalize(1.0) == hi && r.denormalize(0.5) == 0.0);
  EXPECT_TRUE(r.denormalize(0.25) == -7.5e307);
  // Beyond the range the value saturates at the largest double instead of overflowing.
  EXPECT_TRUE(r.denormalize(1.2) == DBL_MAX && r.denormalize(-0.2) == -DBL_MAX);
  EXPECT_TRUE(std::isnan(r.denormalize(std::nan(""))));
  // Widths in source units: finite up to DBL_MAX, inf beyond (as they are).
  EXPECT_TRUE(r.span(0.5) == 1.5e308 && std::isinf(r.span(1.0)));
  EXPECT_NEAR_REL(r.span(-0.1), -3e307, 1e-15, 0.0);
  EXPECT_NEAR_REL(r.perWidth(3e307), 0.1, 1e-15, 0.0);
  // Round trips within rounding over the whole range (and an asymmetric range).
  for (const auto& e : { std::make_pair(lo, hi), std::make_pair(-1e308, 1.7e308), std::make_pair(-DBL_MAX, DBL_MAX) })
  {
    const ValueRange q(e.first, e.second);
    EXPECT_TRUE(q.halved());
    double worst = 0.0;
    for (int i = 0; i <= 1000; ++i)
    {
      const double t = i / 1000.0;
      const double v = q.denormalize(t);
      EXPECT_TRUE(std::isfinite(v));
      worst = std::max(worst, std::fabs(q.normalize(v) - t));
    }
    EXPECT_TRUE(worst <= 4 * DBL_EPSILON);
  }
}

NV_TEST(the_normalisation_agrees_with_the_scaled_down_range)
{
  // +-1.5 * 2^1023 and +-1.5: the same normalised values (exact scaling) up to the last bit or two.
  const ValueRange big(-1.5 * kHuge, 1.5 * kHuge), small(-1.5, 1.5);
  EXPECT_TRUE(big.halved() && !small.halved());
  for (double v = -1.5; v <= 1.5; v += 0.0625)
  {
    EXPECT_NEAR_REL(big.normalize(v * kHuge), small.normalize(v), 0.0, 4e-16);
    EXPECT_TRUE(big.denormalize(small.normalize(v)) == small.denormalize(small.normalize(v)) * kHuge);
  }
}

NV_TEST(a_field_wider_than_the_largest_double_trains_decodes_and_measures)
{
  // The same field at +-1.5 and at +-1.5 * 2^1023 (a range of 2.7e308): the same training targets to float
  // precision, so the same PSNR; figures finite, decoded values finite and in range.
  const int n = 24, steps = 150;
  const std::vector<double> smallData = field(n, 1.0), bigData = field(n, kHuge);
  const VolumeView smallVol = nvtest::cubeView(smallData, n), bigVol = nvtest::cubeView(bigData, n);
  EXPECT_TRUE(std::isinf(bigVol.valueMax - bigVol.valueMin));
  const Model ms = trainOn(smallVol, steps), mb = trainOn(bigVol, steps);
  const ErrorStats es = nvtest::compareToSource(ms, smallVol, Device::Cpu, 2);
  const ErrorStats eb = nvtest::compareToSource(mb, bigVol, Device::Cpu, 2);
  std::printf("  +-1.5: PSNR %.3f dB, max error %.4g; +-1.35e308: PSNR %.3f dB, max error %.4g\n", es.psnr,
    es.maxAbsError, eb.psnr, eb.maxAbsError);
  EXPECT_TRUE(eb.nonFinite == 0 && eb.count == int64_t(n) * n * n);
  EXPECT_TRUE(std::isfinite(eb.psnr) && eb.psnr > 25.0 && std::isfinite(eb.maxAbsError));
  EXPECT_NEAR_REL(eb.psnr, es.psnr, 0.0, 0.05);
  EXPECT_NEAR_REL(eb.maxAbsError / kHuge, es.maxAbsError, 0.01, 0.0);

  // Decoded in double: finite, within the range (saturated at most), the error as compareDecoded reports it.
  auto session = nvtest::session(mb, Device::Cpu, 2);
  std::vector<double> decoded(bigData.size());
  decodeGridValues(*session, n, n, n, 0, n, decoded.data());
  // Measured here on the values scaled back by 2^-1023 (exact), relative to the range.
  const double width = bigVol.valueMax / kHuge - bigVol.valueMin / kHuge;
  double se = 0.0;
  bool finite = true;
  for (size_t i = 0; i < decoded.size(); ++i)
  {
    finite = finite && std::isfinite(decoded[i]) && std::fabs(decoded[i]) <= DBL_MAX;
    const double d = (decoded[i] / kHuge - bigData[i] / kHuge) / width;
    se += d * d;
  }
  EXPECT_TRUE(finite);
  const double psnr = 10.0 * std::log10(1.0 / (se / double(decoded.size())));
  EXPECT_NEAR_REL(psnr, eb.psnr, 0.0, 0.01);
  const ErrorStats ed = compareDecoded(decoded.data(), bigVol, bigVol.valueMin, bigVol.valueMax, 2);
  EXPECT_NEAR_REL(ed.psnr, eb.psnr, 0.0, 1e-9);
  // The max error in units of the range: the small field's (finite also where the source-unit figure overflows).
  EXPECT_NEAR_REL(ed.maxErrorOfRange, es.maxErrorOfRange, 0.01, 0.0);
  EXPECT_NEAR_REL(ed.maxErrorOfRange * 2.0 * (bigVol.valueMax / 2.0 - bigVol.valueMin / 2.0), ed.maxAbsError, 0.0, 1e-9);
  // An error of more than DBL_MAX in source units: maxAbsError inf, its share of the range finite (not a divergence).
  std::vector<double> far(decoded);
  far[3] = bigData[3] > 0.0 ? -DBL_MAX : DBL_MAX; // farther from the source value than DBL_MAX
  const ErrorStats over = compareDecoded(far.data(), bigVol, bigVol.valueMin, bigVol.valueMax, 2);
  EXPECT_TRUE(over.nonFinite == 0 && std::isfinite(over.psnr) && std::isinf(over.maxAbsError));
  const double share = std::fabs(far[3] / 2.0 - bigData[3] / 2.0) / (bigVol.valueMax / 2.0 - bigVol.valueMin / 2.0);
  EXPECT_NEAR_REL(over.maxErrorOfRange, share, 0.0, 1e-12);

  // A NaN in the decoded values is never a score.
  decoded[17] = std::nan("");
  const ErrorStats bad = compareDecoded(decoded.data(), bigVol, bigVol.valueMin, bigVol.valueMax, 2);
  EXPECT_TRUE(bad.nonFinite == 1 && std::isnan(bad.psnr) && std::isinf(bad.maxAbsError) &&
    std::isinf(bad.maxErrorOfRange));

  // The network file keeps the range and decodes the same values.
  const Model back = deserialize(serialize(mb));
  EXPECT_TRUE(back.source.valueMin == mb.source.valueMin && back.source.valueMax == mb.source.valueMax);
  const ErrorStats eback = nvtest::compareToSource(back, bigVol, Device::Cpu, 2);
  EXPECT_TRUE(eback.psnr == eb.psnr);
}

NV_TEST(a_float_output_saturates_at_the_largest_float)
{
  // A network overshooting a float32 field that reaches FLT_MAX decodes to FLT_MAX, never to inf.
  EXPECT_TRUE(storedValue<float>(3.5e38) == FLT_MAX && storedValue<float>(-1e300) == -FLT_MAX);
  EXPECT_TRUE(storedValue<float>(1.5) == 1.5f && storedValue<float>(double(FLT_MAX)) == FLT_MAX);
  EXPECT_TRUE(std::isnan(storedValue<float>(std::nan(""))));
  EXPECT_TRUE(storedValue<double>(DBL_MAX) == DBL_MAX && storedValue<double>(-3.5e38) == -3.5e38);
}

NV_TEST(a_range_wider_than_the_largest_double_renders)
{
  // One network, its range given as +-1.5 or as +-1.5 * 2^1023, the transfer function over the same range: the
  // same transfer-function mapping and the same pictures.
  const int n = 24;
  const std::vector<double> data = field(n, 1.0);
  const Model small = trainOn(nvtest::cubeView(data, n), 40);
  Model big = small;
  big.source.valueMin = small.source.valueMin * kHuge;
  big.source.valueMax = small.source.valueMax * kHuge;
  const RenderRequest qs = nvtest::blobRequest(small, RenderPath::Decode, ShadingMode::RayMarch, 48, 48);
  const RenderRequest qb = nvtest::blobRequest(big, RenderPath::Decode, ShadingMode::RayMarch, 48, 48);
  const RenderSetup ss = makeRenderSetup(qs, small.source), sb = makeRenderSetup(qb, big.source);
  EXPECT_TRUE(std::isfinite(sb.params.tfScale) && std::isfinite(sb.params.tfShift));
  EXPECT_NEAR_REL(sb.params.tfScale, ss.params.tfScale, 1e-6, 0.0);
  EXPECT_NEAR_REL(sb.params.tfShift, ss.params.tfShift, 0.0, 1e-5);
  for (int path = 0; path < 3; ++path)
  {
    RenderResult a, b;
    nvtest::session(small, Device::Cpu, 2)->render(nvtest::blobRequest(small, RenderPath(path), ShadingMode::RayMarch,
                                                     48, 48), a);
    nvtest::session(big, Device::Cpu, 2)->render(nvtest::blobRequest(big, RenderPath(path), ShadingMode::RayMarch,
                                                   48, 48), b);
    const double p = nvtest::psnr(a.rgba, b.rgba);
    double alpha = 0.0;
    for (size_t i = 3; i < a.rgba.size(); i += 4)
      alpha += a.rgba[i];
    std::printf("  path %d: image PSNR %.1f dB between the ranges (mean opacity %.3f)\n", path, p,
      alpha / (a.rgba.size() / 4));
    EXPECT_TRUE(p > 60.0 && alpha > 0.01 * (a.rgba.size() / 4));
  }
}

NV_TEST_MAIN()
