// Particle fields (Cuda/Particles): kernel normalisation, the locator against a brute-force sum, the interpolated
// reconstruction of a procedural set against the analytic function it samples, the density of a lattice, the
// empty field outside the support, and the treatment of bad particles.
#include "Particles/ParticleField.h"
#include "TestHarness.h"

#include "Core/HashGridMath.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

using namespace nv;

namespace
{
const ParticleKernel kKernels[3] = { ParticleKernel::Gaussian, ParticleKernel::CubicSpline,
  ParticleKernel::WendlandC2 };

double analytic(const double* p)
{
  return std::sin(3.0 * p[0]) + std::cos(2.0 * p[1]) * p[2] + 0.5 * p[2] * p[2];
}

/// n^3 particles on a lattice of spacing 1/n in [0,1)^3, jittered by `jitter` spacings (seeded); values analytic().
struct Lattice
{
  std::vector<double> xyz, values;
  Lattice(int n, double jitter)
  {
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
        {
          float u[3];
          randomPoint(7, 0, uint64_t((k * n + j) * n + i), u);
          const double p[3] = { (i + 0.5 + jitter * (u[0] - 0.5)) / n, (j + 0.5 + jitter * (u[1] - 0.5)) / n,
            (k + 0.5 + jitter * (u[2] - 0.5)) / n };
          xyz.insert(xyz.end(), p, p + 3);
          values.push_back(analytic(p));
        }
  }
  ParticleInput input() const { return ParticleInput{ xyz.data(), values.data(), nullptr, int64_t(values.size()) }; }
};
} // namespace

NV_TEST(KernelNormalisation)
{
  for (ParticleKernel k : kKernels)
  {
    // The midpoint rule of 4 pi q^2 W(q) over [0, 1] (the truncated Gaussian jumps to 0 at q = 1).
    const int n = 200000;
    double sum = 0.0;
    for (int i = 0; i < n; ++i)
    {
      const double q = (i + 0.5) / n;
      sum += 4.0 * 3.14159265358979323846 * q * q * particleKernel(k, q);
    }
    EXPECT_NEAR_REL(sum / n, 1.0, 0.0, 1e-8);
    EXPECT_TRUE(particleKernel(k, 1.0) == 0.0 && particleKernel(k, 1.5) == 0.0);
    EXPECT_TRUE(particleKernel(k, 0.0) > particleKernel(k, 0.5) && particleKernel(k, 0.5) > 0.0);
  }
}

NV_TEST(LocatorMatchesBruteForce)
{
  // 3000 random particles with radii from 0.02 to 0.12; 2000 random queries, some outside the box.
  const int n = 3000;
  std::vector<double> xyz(3 * n), values(n), radii(n);
  for (int i = 0; i < n; ++i)
  {
    float u[3], v[3];
    randomPoint(11, 1, uint64_t(i), u);
    randomPoint(11, 2, uint64_t(i), v);
    for (int a = 0; a < 3; ++a)
      xyz[3 * i + a] = u[a];
    values[i] = v[0] * 10.0 - 3.0;
    radii[i] = 0.02 + 0.1 * v[1];
  }
  for (ParticleKernel k : kKernels)
    for (ParticleFieldMode mode : { ParticleFieldMode::Interpolate, ParticleFieldMode::Density })
    {
      ParticleField field({ xyz.data(), values.data(), radii.data(), n }, { mode, k, 0.0 });
      int inside = 0, close = 0;
      double worst = 0.0;
      std::vector<double> errors, scales; // the density's scale: its largest sum of |terms| over the queries
      for (int q = 0; q < 2000; ++q)
      {
        float u[3];
        randomPoint(13, 3, uint64_t(q), u);
        const double x[3] = { 1.2 * u[0] - 0.1, 1.2 * u[1] - 0.1, 1.2 * u[2] - 0.1 };
        double sw = 0.0, swf = 0.0, magnitude = 0.0; // magnitude: the sum of |terms|, the scale of rounding
        for (int i = 0; i < n; ++i)
        {
          const double dx = x[0] - xyz[3 * i], dy = x[1] - xyz[3 * i + 1], dz = x[2] - xyz[3 * i + 2];
          const double r = radii[i], w = particleKernel(k, std::sqrt(dx * dx + dy * dy + dz * dz) / r);
          sw += w / (r * r * r);
          swf += w / (r * r * r) * float(values[i]);
          magnitude += w / (r * r * r) * std::fabs(float(values[i]));
        }
        double v = std::numeric_limits<double>::quiet_NaN();
        const bool in = field.evaluate(x, v);
        EXPECT_TRUE(in == (sw > 0.0));
        if (in && sw > 0.0)
        {
          ++inside;
          const double expected = mode == ParticleFieldMode::Density ? swf : swf / sw;
          errors.push_back(std::fabs(v - expected));
          scales.push_back(mode == ParticleFieldMode::Density ? magnitude : magnitude / sw);
        }
      }
      const double densityScale = *std::max_element(scales.begin(), scales.end());
      for (size_t e = 0; e < errors.size(); ++e)
      {
        const double error = errors[e] / (mode == ParticleFieldMode::Density ? densityScale : scales[e]);
        worst = std::max(worst, error);
        close += error < 1e-5 ? 1 : 0;
      }
      // Errors relative to the sum of |terms| (the density's largest). The locator stores positions and radii in float: the cubic spline and Wendland C2 vanish smoothly at the
      // radius, so the rounding is invisible (1e-4); the truncated Gaussian jumps there (to e^-4.5 of its peak), so a
      // particle that rounding moves across the radius shifts a sum: 98% within 1e-5, all within 1e-2.
      std::printf("  %s, %s: %d of %d within 1e-5, worst %.2e\n", particleKernelName(k),
        mode == ParticleFieldMode::Density ? "density" : "interpolated", close, inside, worst);
      EXPECT_TRUE(k == ParticleKernel::Gaussian ? (close >= 0.98 * inside && worst < 1e-2) : worst < 1e-4);
      EXPECT_TRUE(inside > 1000 && inside < 2000); // the queries outside the box found no support
    }
}

NV_TEST(InterpolationMatchesAnalytic)
{
  // 40^3 jittered particles, automatic radius (2 mean spacings = 0.05): the normalised reconstruction at 4000 random
  // points at least one radius inside the box is within 0.025 of the analytic function (range about 2.6; measured
  // 0.013 to 0.018) and within 0.005 in RMS.
  const Lattice lattice(40, 0.5);
  for (ParticleKernel k : kKernels)
  {
    ParticleField field(lattice.input(), { ParticleFieldMode::Interpolate, k, 0.0 });
    EXPECT_NEAR_REL(field.meanSpacing(), 1.0 / 40.0, 0.05, 0.0);
    EXPECT_NEAR_REL(field.maxRadius(), 2.0 / 40.0, 0.05, 0.0);
    std::vector<double> points(3 * 4000), values(4000);
    for (int q = 0; q < 4000; ++q)
    {
      float u[3];
      randomPoint(17, 4, uint64_t(q), u);
      for (int a = 0; a < 3; ++a)
        points[3 * q + a] = 0.06 + 0.88 * u[a];
    }
    EXPECT_TRUE(field.evaluateMany(points.data(), 4000, values.data(), 2) == 4000);
    double maxError = 0.0, squares = 0.0;
    for (int q = 0; q < 4000; ++q)
    {
      const double e = values[q] - analytic(&points[3 * q]);
      maxError = std::max(maxError, std::fabs(e));
      squares += e * e;
    }
    const double rms = std::sqrt(squares / 4000.0);
    std::printf("  %s: reconstruction - analytic: max %.5f, RMS %.5f\n", particleKernelName(k), maxError, rms);
    EXPECT_TRUE(maxError < 0.025 && rms < 0.005);
  }
}

NV_TEST(DensityOfLattice)
{
  // A regular lattice of spacing d with masses d^3: the density is 1 inside (within 1.5%), and integrates to the
  // total mass.
  const int n = 30;
  Lattice lattice(n, 0.0);
  const double mass = 1.0 / (double(n) * n * n);
  for (double& v : lattice.values)
    v = mass;
  for (ParticleKernel k : kKernels)
  {
    ParticleField field(lattice.input(), { ParticleFieldMode::Density, k, 2.5 / n });
    for (int q = 0; q < 200; ++q)
    {
      float u[3];
      randomPoint(19, 5, uint64_t(q), u);
      const double x[3] = { 0.2 + 0.6 * u[0], 0.2 + 0.6 * u[1], 0.2 + 0.6 * u[2] };
      double v = 0.0;
      EXPECT_TRUE(field.evaluate(x, v));
      EXPECT_NEAR_REL(v, 1.0, 0.015, 0.0);
    }
  }
}

NV_TEST(EmptyOutsideSupport)
{
  const double xyz[6] = { 0.0, 0.0, 0.0, 1.0, 0.0, 0.0 }, values[2] = { 2.0, 4.0 };
  ParticleField field({ xyz, values, nullptr, 2 }, { ParticleFieldMode::Interpolate, ParticleKernel::WendlandC2, 0.3 });
  double v = -1.0;
  const double near[3] = { 0.299, 0.0, 0.0 }, gap[3] = { 0.5, 0.0, 0.0 }, beyond[3] = { -0.301, 0.0, 0.0 };
  EXPECT_TRUE(field.evaluate(near, v) && v == 2.0);
  EXPECT_TRUE(!field.evaluate(gap, v) && !field.evaluate(beyond, v));
  double many[2];
  const double points[6] = { 0.5, 0.0, 0.0, 0.9, 0.0, 0.0 };
  EXPECT_TRUE(field.evaluateMany(points, 2, many, 1) == 1 && std::isnan(many[0]) && many[1] == 4.0);
}

NV_TEST(BadParticles)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // All at one point: refused with an automatic radius, a ball with a constant one.
  const double same[9] = { 1, 2, 3, 1, 2, 3, 1, 2, 3 }, values[3] = { 1, 2, 3 };
  EXPECT_THROW_MSG(ParticleField({ same, values, nullptr, 3 }, {}), "lie at one point");
  ParticleField ball({ same, values, nullptr, 3 }, { ParticleFieldMode::Interpolate, ParticleKernel::CubicSpline, 0.5 });
  double v = 0.0;
  const double inBall[3] = { 1.2, 2.0, 3.0 };
  EXPECT_TRUE(ball.evaluate(inBall, v) && std::fabs(v - 2.0) < 1e-6);
  // NaN positions and values, zero and negative radii: skipped and counted.
  const double xyz[15] = { 0, 0, 0, nan, 0, 0, 1, 1, 1, 0.5, 0.5, 0.5, 0.2, 0.2, 0.2 };
  const double vals[5] = { 1, 2, nan, 4, 5 }, radii[5] = { 0.5, 0.5, 0.5, 0.0, -1.0 };
  ParticleField partial({ xyz, vals, radii, 5 }, {});
  EXPECT_TRUE(partial.counts().Used == 1 && partial.counts().BadPosition == 1 && partial.counts().BadValue == 1 &&
    partial.counts().BadRadius == 2);
  const double origin[3] = { 0.1, 0, 0 };
  EXPECT_TRUE(partial.evaluate(origin, v) && v == 1.0);
  const double badRadii[2] = { 0.0, nan };
  EXPECT_THROW_MSG(ParticleField({ xyz, vals, badRadii, 1 }, {}), "none of the 1 particles");
  EXPECT_THROW_MSG(ParticleField({ xyz, vals, nullptr, 1 }, { ParticleFieldMode::Interpolate,
                     ParticleKernel::Gaussian, -1.0 }), "radius must be >= 0");
}

NV_TEST(UnitsDoNotMatter)
{
  // The same particles in centimetres of a galaxy (x 1e24) and in femtometres (x 1e-15): the same interpolated values,
  // the density scaled by 1 / scale^3 (1/R^3 would leave float's range without the box units).
  const Lattice lattice(12, 0.5);
  for (double scale : { 1e24, 1e-15 })
  {
    std::vector<double> xyz(lattice.xyz);
    for (double& c : xyz)
      c *= scale;
    for (ParticleFieldMode mode : { ParticleFieldMode::Interpolate, ParticleFieldMode::Density })
    {
      ParticleField unit(lattice.input(), { mode, ParticleKernel::WendlandC2, 0.0 });
      ParticleField scaled({ xyz.data(), lattice.values.data(), nullptr, int64_t(lattice.values.size()) },
        { mode, ParticleKernel::WendlandC2, 0.0 });
      EXPECT_NEAR_REL(scaled.maxRadius(), unit.maxRadius() * scale, 1e-6, 0.0);
      for (int q = 0; q < 50; ++q)
      {
        float u[3];
        randomPoint(23, 6, uint64_t(q), u);
        const double x[3] = { 0.2 + 0.6 * u[0], 0.2 + 0.6 * u[1], 0.2 + 0.6 * u[2] };
        const double xs[3] = { x[0] * scale, x[1] * scale, x[2] * scale };
        double a = 0.0, b = 0.0;
        EXPECT_TRUE(unit.evaluate(x, a) && scaled.evaluate(xs, b));
        const double expected = mode == ParticleFieldMode::Density ? a / (scale * scale * scale) : a;
        EXPECT_NEAR_REL(b, expected, 1e-5, 0.0);
      }
    }
  }
}

NV_TEST(HugeRadiiStayCheap)
{
  // 20^3 jittered particles of radius 0.1 (about 33 neighbours each) and 10 of them with a radius of 5 boxes (a
  // bad smoothing length or a unit slip): the locator files the 10 in a radius class of their own, so a query visits
  // about as many particles as without them plus the 10 (a single grid of the largest radius: all 8000); the values
  // match a brute-force sum. Radii above 1000 boxes are clamped and counted.
  const Lattice lattice(20, 0.5);
  const int64_t n = int64_t(lattice.values.size());
  std::vector<double> radii(size_t(n), 0.1);
  for (int i = 0; i < 10; ++i)
    radii[size_t(i * 797)] = 5.0;
  ParticleField plain({ lattice.xyz.data(), lattice.values.data(), nullptr, n },
    { ParticleFieldMode::Interpolate, ParticleKernel::WendlandC2, 0.1 });
  ParticleField huge({ lattice.xyz.data(), lattice.values.data(), radii.data(), n },
    { ParticleFieldMode::Interpolate, ParticleKernel::WendlandC2, 0.0 });
  EXPECT_TRUE(plain.radiusClasses() == 1 && huge.radiusClasses() == 2);
  double plainVisits = 0.0, hugeVisits = 0.0, worst = 0.0;
  for (int q = 0; q < 500; ++q)
  {
    float u[3];
    randomPoint(29, 7, uint64_t(q), u);
    const double x[3] = { u[0], u[1], u[2] };
    plainVisits += double(plain.candidates(x)) / 500.0;
    hugeVisits += double(huge.candidates(x)) / 500.0;
    double sw = 0.0, swf = 0.0, v = 0.0;
    for (int64_t i = 0; i < n; ++i)
    {
      const double* p = &lattice.xyz[size_t(3 * i)];
      const double r = radii[size_t(i)];
      const double d = std::sqrt((x[0] - p[0]) * (x[0] - p[0]) + (x[1] - p[1]) * (x[1] - p[1]) +
        (x[2] - p[2]) * (x[2] - p[2]));
      const double w = particleKernel(ParticleKernel::WendlandC2, d / r) / (r * r * r);
      sw += w;
      swf += w * float(lattice.values[size_t(i)]);
    }
    EXPECT_TRUE(huge.evaluate(x, v));
    worst = std::max(worst, std::fabs(v - swf / sw));
  }
  std::printf("  visits per query: %.1f with radius 0.1 only, %.1f with 10 radii of 5 boxes; worst |diff| %.2e\n",
    plainVisits, hugeVisits, worst);
  EXPECT_TRUE(hugeVisits < plainVisits + 10.5 && hugeVisits > 10.0 && worst < 1e-4);
  // A radius of 1e9 boxes: clamped to 1000 boxes, counted, named in the description; the field stays finite.
  radii[0] = 1e9;
  ParticleField clamped({ lattice.xyz.data(), lattice.values.data(), radii.data(), n },
    { ParticleFieldMode::Density, ParticleKernel::CubicSpline, 0.0 });
  EXPECT_TRUE(clamped.counts().ClampedRadius == 1 && clamped.radiusClasses() == 3);
  const double* b = clamped.bounds();
  EXPECT_NEAR_REL(clamped.maxRadius(), 1000.0 * std::max({ b[1] - b[0], b[3] - b[2], b[5] - b[4] }), 1e-6, 0.0);
  EXPECT_TRUE(clamped.describe().find("1 radii clamped to 1000 x the box") != std::string::npos);
  const double centre[3] = { 0.5, 0.5, 0.5 }, far[3] = { 40.0, 0.5, 0.5 };
  double inside = 0.0, outside = 0.0;
  EXPECT_TRUE(clamped.evaluate(centre, inside) && std::isfinite(inside) && inside > 0.0);
  EXPECT_TRUE(clamped.evaluate(far, outside) && outside > 0.0 && outside < inside);
}

NV_TEST(KernelSumsOfParts)
{
  // A set split in two at x = 0.5 (as two ranks hold it): the parts' kernel sums, added, give the whole set's field
  // in both modes, inside and outside the support (the distributed reconstruction, vtkNeuralCompressParticlePiece.h).
  const Lattice lattice(16, 0.8);
  const int64_t n = int64_t(lattice.values.size());
  std::vector<double> xyz[2], values[2];
  for (int64_t i = 0; i < n; ++i)
  {
    const int side = lattice.xyz[size_t(3 * i)] < 0.5 ? 0 : 1;
    xyz[side].insert(xyz[side].end(), &lattice.xyz[size_t(3 * i)], &lattice.xyz[size_t(3 * i)] + 3);
    values[side].push_back(lattice.values[size_t(i)]);
  }
  for (ParticleFieldMode mode : { ParticleFieldMode::Interpolate, ParticleFieldMode::Density })
  {
    const ParticleOptions options{ mode, ParticleKernel::WendlandC2, 0.09 };
    const ParticleField whole(lattice.input(), options);
    const ParticleField left({ xyz[0].data(), values[0].data(), nullptr, int64_t(values[0].size()) }, options);
    const ParticleField right({ xyz[1].data(), values[1].data(), nullptr, int64_t(values[1].size()) }, options);
    const int64_t q = 2000;
    std::vector<double> points(static_cast<size_t>(3 * q)), expected(static_cast<size_t>(q));
    std::vector<double> sums[4] = { std::vector<double>(size_t(q)), std::vector<double>(size_t(q)),
      std::vector<double>(size_t(q)), std::vector<double>(size_t(q)) };
    for (int64_t i = 0; i < q; ++i)
    {
      float u[3];
      randomPoint(31, 3, uint64_t(i), u);
      for (int a = 0; a < 3; ++a)
        points[size_t(3 * i + a)] = 1.2 * u[a] - 0.1; // beyond the support near the box's faces too
    }
    whole.evaluateMany(points.data(), q, expected.data(), 1);
    left.kernelSums(points.data(), q, sums[0].data(), sums[1].data(), 2);
    right.kernelSums(points.data(), q, sums[2].data(), sums[3].data(), 2);
    double worst = 0.0, peak = 0.0; // the largest |difference| and |value|: the tolerance is relative to the range
    for (double v : expected)
      peak = std::isnan(v) ? peak : std::max(peak, std::fabs(v));
    int64_t mismatched = 0, outside = 0;
    for (size_t i = 0; i < size_t(q); ++i)
    {
      const double weight = sums[1][i] + sums[3][i], weighted = sums[0][i] + sums[2][i];
      outside += std::isnan(expected[i]) ? 1 : 0;
      if (std::isnan(expected[i]) != !(weight > 0.0))
        ++mismatched;
      else if (weight > 0.0)
      {
        const double value = mode == ParticleFieldMode::Density ? weighted : weighted / weight;
        worst = std::max(worst, std::fabs(value - expected[i]) / peak);
      }
    }
    const char* modeName = mode == ParticleFieldMode::Density ? "density" : "interpolate";
    std::printf("  %s: %lld of %lld points outside the support, support mismatches %lld, worst |diff| %.2e of the "
                "largest |value|\n",
      modeName, (long long)outside, (long long)q, (long long)mismatched, worst);
    EXPECT_TRUE(mismatched == 0 && outside > 0 && outside < q && worst < 1e-5);
  }
}

NV_TEST_MAIN()
