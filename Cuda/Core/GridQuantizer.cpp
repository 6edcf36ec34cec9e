#include "GridQuantizer.h"

#include <algorithm>
#include <cfloat>
#include <limits>

namespace nv
{
namespace
{
constexpr size_t kMaxTried = 65536; ///< values tried per clipping level
constexpr int kRefinements = 3;     ///< least-squares refinements of the best clipping level's step
}

bool GridQuantizer::validStep(float step)
{
  return step == 0.0f || (std::isfinite(step) && step >= FLT_MIN && std::isfinite(step * float(kMaxCode)));
}

double GridQuantizer::squaredError(const float* w, size_t n, float step, size_t stride)
{
  double e = 0.0;
  for (size_t i = 0; i < n; i += stride)
  {
    if (!std::isfinite(w[i]))
      continue;
    const double d = double(w[i]) - double(value(code(w[i], step), step));
    e += d * d;
  }
  return e;
}

float GridQuantizer::chooseStep(const float* w, size_t n)
{
  float top = 0.0f;
  for (size_t i = 0; i < n; ++i)
    if (std::isfinite(w[i]))
      top = std::max(top, std::fabs(w[i]));
  if (!(top >= float(kMaxCode) * FLT_MIN))
    return 0.0f;
  const size_t stride = std::max<size_t>(1, (n + kMaxTried - 1) / kMaxTried);
  auto admissible = [](float s) {
    while (!validStep(s))
      s = std::nextafter(s, 0.0f); // only at the top of the float range
    return s;
  };
  float best = admissible(top / float(kMaxCode));
  double bestError = squaredError(w, n, best, stride);
  for (int k = 19; k >= 6; --k) // clipping at 0.95, 0.9, ..., 0.3 of the largest value
  {
    const float s = admissible(top * (0.05f * float(k)) / float(kMaxCode));
    const double e = squaredError(w, n, s, stride);
    if (e < bestError)
    {
      best = s;
      bestError = e;
    }
  }
  // The step that minimises the error of the current codes (least squares), while it lowers the error.
  for (int r = 0; r < kRefinements; ++r)
  {
    double wk = 0.0, kk = 0.0;
    for (size_t i = 0; i < n; i += stride)
    {
      if (!std::isfinite(w[i]))
        continue;
      const double k = code(w[i], best);
      wk += double(w[i]) * k;
      kk += k * k;
    }
    if (!(kk > 0.0 && wk > 0.0))
      break;
    const double fitted = wk / kk;
    if (!(fitted >= double(FLT_MIN) && fitted < double(FLT_MAX) / kMaxCode))
      break;
    const float s = admissible(static_cast<float>(fitted));
    const double e = squaredError(w, n, s, stride);
    if (!(e < bestError))
      break;
    best = s;
    bestError = e;
  }
  return best;
}

bool GridQuantizer::onGrid(const float* w, size_t n, float step)
{
  if (!validStep(step))
    return false;
  for (size_t i = 0; i < n; ++i)
    if (!(value(code(w[i], step), step) == w[i]))
      return false;
  return true;
}

} // namespace nv
