#include "CpuAdam.h"

#include "ThreadPool.h"

#include <cmath>

namespace nv
{

CpuAdam::CpuAdam(const OptimizerConfig& config, size_t paramCount)
  : Config(config)
  , M(paramCount, 0.0f)
  , V(paramCount, 0.0f)
{
}

void CpuAdam::updateRange(float* p, float* g, float* m, float* v, size_t begin, size_t end, float lr, float beta1,
  float beta2, float eps, double bc1, double bc2)
{
  const float stepSize = static_cast<float>(lr / bc1);
  const float invSqrtBc2 = static_cast<float>(1.0 / std::sqrt(bc2));
  const float a1 = 1.0f - beta1, a2 = 1.0f - beta2;
  for (size_t i = begin; i < end; ++i)
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

void CpuAdam::update(float* params, float* grad, int64_t step, ThreadPool& pool)
{
  const double bc1 = 1.0 - std::pow(Config.beta1, static_cast<double>(step));
  const double bc2 = 1.0 - std::pow(Config.beta2, static_cast<double>(step));
  const float lr = static_cast<float>(Config.learningRateAt(step));
  float* m = M.data();
  float* v = V.data();
  const float b1 = static_cast<float>(Config.beta1), b2 = static_cast<float>(Config.beta2);
  const float eps = static_cast<float>(Config.epsilon);
  pool.parallelFor(static_cast<int64_t>(M.size()), [&](int64_t b, int64_t e, int) {
    updateRange(params, grad, m, v, static_cast<size_t>(b), static_cast<size_t>(e), lr, b1, b2, eps, bc1, bc2);
  });
}

} // namespace nv
