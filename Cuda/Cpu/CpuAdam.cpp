#include "CpuAdam.h"

#include "CpuGemm.h"
#include "ThreadPool.h"

#if defined(__SSE__)
#include <immintrin.h>
#endif

#include <cmath>

namespace nv
{

CpuAdam::CpuAdam(const OptimizerConfig& config, size_t paramCount)
  : Config(config)
  , FirstMoment(paramCount, 0.0f)
  , SecondMoment(paramCount, 0.0f)
{
}

namespace
{
inline gemm::Vec vsqrt(gemm::Vec x)
{
#if defined(__AVX512F__)
  return (gemm::Vec)_mm512_sqrt_ps((__m512)x);
#elif defined(__AVX__)
  return (gemm::Vec)_mm256_sqrt_ps((__m256)x);
#elif defined(__SSE__)
  return (gemm::Vec)_mm_sqrt_ps((__m128)x);
#else
  for (int k = 0; k < gemm::kVW; ++k)
    x[k] = std::sqrt(x[k]);
  return x;
#endif
}
} // namespace

void CpuAdam::updateRange(float* p, float* g, float* m, float* v, size_t begin, size_t end, float lr, float beta1,
  float beta2, float eps, double bc1, double bc2)
{
  const float stepSize = static_cast<float>(lr / bc1);
  const float invSqrtBc2 = static_cast<float>(1.0 / std::sqrt(bc2));
  const float a1 = 1.0f - beta1, a2 = 1.0f - beta2;
  // Vectors (the same operations per element: IEEE square root and division), then the remainder.
  using gemm::Vec;
  using gemm::kVW;
  const Vec b1v = gemm::splat(beta1), b2v = gemm::splat(beta2), a1v = gemm::splat(a1), a2v = gemm::splat(a2);
  const Vec sv = gemm::splat(stepSize), cv = gemm::splat(invSqrtBc2), ev = gemm::splat(eps);
  size_t i = begin;
  for (; i + kVW <= end; i += kVW)
  {
    const Vec gi = gemm::load(g + i);
    gemm::store(g + i, Vec{});
    const Vec mi = b1v * gemm::load(m + i) + a1v * gi;
    const Vec vi = b2v * gemm::load(v + i) + a2v * gi * gi;
    gemm::store(m + i, mi);
    gemm::store(v + i, vi);
    gemm::store(p + i, gemm::load(p + i) - sv * mi / (vsqrt(vi) * cv + ev));
  }
  for (; i < end; ++i)
  {
    const float gi = g[i];
    g[i] = 0.0f;
    const float mi = beta1 * m[i] + a1 * gi;
    const float vi = beta2 * v[i] + a2 * gi * gi;
    m[i] = mi;
    v[i] = vi;
    p[i] -= stepSize * mi / (std::sqrt(vi) * invSqrtBc2 + eps);
  }
}

void CpuAdam::update(float* params, float* grad, int64_t step, ThreadPool& pool, double rateScale)
{
  const double bc1 = 1.0 - std::pow(Config.beta1, static_cast<double>(step));
  const double bc2 = 1.0 - std::pow(Config.beta2, static_cast<double>(step));
  const float lr = static_cast<float>(Config.learningRateAt(step) * rateScale);
  float* m = FirstMoment.data();
  float* v = SecondMoment.data();
  const float b1 = static_cast<float>(Config.beta1), b2 = static_cast<float>(Config.beta2);
  const float eps = static_cast<float>(Config.epsilon);
  pool.parallelFor(static_cast<int64_t>(FirstMoment.size()), [&](int64_t b, int64_t e, int) {
    updateRange(params, grad, m, v, static_cast<size_t>(b), static_cast<size_t>(e), lr, b1, b2, eps, bc1, bc2);
  });
}

} // namespace nv
