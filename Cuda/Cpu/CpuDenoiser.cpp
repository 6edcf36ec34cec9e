#include "CpuDenoiser.h"

#include "Core/Error.h"
#include "ThreadPool.h"

namespace nv
{

namespace
{
/// fn(x, y, pixel) for every pixel, rows split over the pool.
template <typename Fn>
void forEachPixel(ThreadPool& pool, const DenoiseParams& p, const Fn& fn)
{
  pool.parallelFor(p.height, [&](int64_t begin, int64_t end, int) {
    for (int64_t y = begin; y < end; ++y)
      for (int x = 0; x < p.width; ++x)
        fn(x, static_cast<int>(y), y * p.width + x);
  });
}
} // namespace

void CpuDenoiser::denoise(ThreadPool& pool, const DenoiseParams& params, const float* noisy, const float* guide,
  const float* moments, float* out)
{
  DenoiseParams p = params;
  NV_CHECK(p.width > 0 && p.height > 0, "denoise: the image is empty");
  NV_CHECK(p.iterations >= 0 && p.iterations <= 10, "denoise: 0..10 a-trous iterations");
  NV_CHECK(p.frames < 2 || moments, "denoise: an accumulation of several frames needs its moments");
  NV_CHECK(out != noisy && out != guide, "denoise: the output may not alias the inputs");
  const size_t pixels = static_cast<size_t>(p.width) * static_cast<size_t>(p.height);
  for (int b = 0; b < 2; ++b)
  {
    Illum[b].resize(4 * pixels);
    Variance[b].resize(pixels);
  }
  float* illum = Illum[0].data();
  float* variance = Variance[0].data();
  forEachPixel(pool, p, [&](int, int, int64_t i) {
    denoise::demodulate(p, noisy + 4 * i, guide + 4 * i, moments ? moments[i] : 0.0f, illum + 4 * i, variance[i]);
  });
  if (p.frames < 2)
    forEachPixel(pool, p, [&](int x, int y, int64_t i) {
      if (variance[i] < 0.0f)
        variance[i] = denoise::spatialVariance(p, x, y, illum);
    });
  RawVariance.assign(Variance[0].begin(), Variance[0].end());
  int cur = 0;
  for (int it = 0; it < p.iterations; ++it)
  {
    const float* inI = Illum[cur].data();
    const float* inV = Variance[cur].data();
    float* outI = Illum[cur ^ 1].data();
    float* outV = Variance[cur ^ 1].data();
    forEachPixel(pool, p, [&](int x, int y, int64_t) {
      denoise::atrousPixel(p, x, y, 1 << it, inI, inV, guide, outI, outV);
    });
    cur ^= 1;
  }
  // Step 4: the raw accumulation's estimated error over the pixels the volume covers (sums per worker, then over
  // the workers).
  std::vector<double> sums(static_cast<size_t>(pool.size()), 0.0), covered(sums.size(), 0.0);
  pool.parallelFor(int64_t(pixels), [&](int64_t begin, int64_t end, int worker) {
    double sum = 0.0, count = 0.0;
    for (int64_t i = begin; i < end; ++i)
      if (denoise::guideCovers(p, guide + 4 * i))
      {
        sum += denoise::rawVarianceOfMean(p, noisy + 4 * i, moments ? moments[i] : 0.0f);
        count += 1.0;
      }
    sums[static_cast<size_t>(worker)] += sum;
    covered[static_cast<size_t>(worker)] += count;
  });
  double total = 0.0, count = 0.0;
  for (size_t w = 0; w < sums.size(); ++w)
  {
    total += sums[w];
    count += covered[w];
  }
  p.rawFade = count > 0.0 ? denoise::fade(p, total / count) : 0.0f;
  const float* result = Illum[cur].data();
  const float* rawVariance = RawVariance.data();
  forEachPixel(pool, p, [&](int x, int y, int64_t) {
    denoise::remodulate(p, x, y, noisy, guide, result, rawVariance, out);
  });
}

} // namespace nv
