// NeuralVolume engine: compareDecoded (Core/Engine.h), the error of a decoded grid against its source, computed on
// the CPU's thread pool whichever backend decoded the grid.
#include "Core/Engine.h"
#include "Core/ValueRange.h"
#include "ThreadPool.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace nv
{

namespace
{
template <typename T>
ErrorStats compareDecodedT(const T* decoded, const VolumeView& v, double valueMin, double valueMax, int threads)
{
  ErrorStats r;
  const ValueRange range(valueMin, valueMax);
  ThreadPool pool(threads);
  std::vector<double> se(pool.size(), 0.0), mx(pool.size(), 0.0), mxn(pool.size(), 0.0);
  std::vector<int64_t> cnt(pool.size(), 0), bad(pool.size(), 0);
  pool.parallelFor(v.count(), [&](int64_t b, int64_t e, int w) {
    for (int64_t i = b; i < e; ++i)
    {
      const double x = v.at(i);
      if (!std::isfinite(x))
        continue;
      if (!std::isfinite(static_cast<double>(decoded[i])))
      {
        ++bad[w];
        ++cnt[w];
        continue;
      }
      // Difference in normalised units first: stays finite for huge ranges (and ranges wider than DBL_MAX).
      const double dn = range.spans() ? range.normalize(static_cast<double>(decoded[i])) - range.normalize(x)
                                      : static_cast<double>(decoded[i]) - x;
      se[w] += dn * dn;
      mx[w] = std::max(mx[w], std::fabs(range.spans() ? range.span(dn) : dn));
      mxn[w] = std::max(mxn[w], std::fabs(dn));
      ++cnt[w];
    }
  });
  double sum = 0.0;
  for (int w = 0; w < pool.size(); ++w)
  {
    sum += se[w];
    r.maxAbsError = std::max(r.maxAbsError, mx[w]);
    r.maxErrorOfRange = std::max(r.maxErrorOfRange, mxn[w]);
    r.count += cnt[w];
    r.nonFinite += bad[w];
  }
  if (r.nonFinite > 0)
  {
    r.mse = r.psnr = std::numeric_limits<double>::quiet_NaN();
    r.maxAbsError = r.maxErrorOfRange = std::numeric_limits<double>::infinity();
    return r;
  }
  r.mse = r.count > 0 ? sum / static_cast<double>(r.count) : 0.0;
  r.psnr = r.mse > 0.0 ? 10.0 * std::log10(1.0 / r.mse) : std::numeric_limits<double>::infinity();
  return r;
}
} // namespace

ErrorStats compareDecoded(const float* decoded, const VolumeView& v, double valueMin, double valueMax, int threads)
{
  return compareDecodedT(decoded, v, valueMin, valueMax, threads);
}

ErrorStats compareDecoded(const double* decoded, const VolumeView& v, double valueMin, double valueMax, int threads)
{
  return compareDecodedT(decoded, v, valueMin, valueMax, threads);
}

} // namespace nv
