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
/// One worker's sums over its range of samples, in locals (the workers' vectors are written once at the end: 16
/// workers updating neighbouring elements per sample shared their cache lines and serialised the pass).
struct CompareSums
{
  double squared = 0.0, maxAbs = 0.0, maxOfRange = 0.0;
  int64_t count = 0, bad = 0;
};

/// Samples [b, e) of a source of type S against the decoded values: a typed loop (no per-sample type switch).
template <typename T, typename S>
CompareSums compareRange(const T* decoded, const S* source, int64_t b, int64_t e, const ValueRange& range)
{
  CompareSums sums;
  const bool spans = range.spans();
  for (int64_t i = b; i < e; ++i)
  {
    const double x = static_cast<double>(source[i]);
    if (!std::isfinite(x))
      continue;
    const double d = static_cast<double>(decoded[i]);
    if (!std::isfinite(d))
    {
      ++sums.bad;
      ++sums.count;
      continue;
    }
    // Difference in normalised units first: stays finite for huge ranges (and ranges wider than DBL_MAX).
    const double dn = spans ? range.normalize(d) - range.normalize(x) : d - x;
    sums.squared += dn * dn;
    sums.maxAbs = std::max(sums.maxAbs, std::fabs(spans ? range.span(dn) : dn));
    sums.maxOfRange = std::max(sums.maxOfRange, std::fabs(dn));
    ++sums.count;
  }
  return sums;
}

template <typename T>
CompareSums compareRangeOf(const T* decoded, const VolumeView& v, int64_t b, int64_t e, const ValueRange& range)
{
  switch (v.type)
  {
    case ScalarType::Int8: return compareRange(decoded, static_cast<const int8_t*>(v.data), b, e, range);
    case ScalarType::UInt8: return compareRange(decoded, static_cast<const uint8_t*>(v.data), b, e, range);
    case ScalarType::Int16: return compareRange(decoded, static_cast<const int16_t*>(v.data), b, e, range);
    case ScalarType::UInt16: return compareRange(decoded, static_cast<const uint16_t*>(v.data), b, e, range);
    case ScalarType::Int32: return compareRange(decoded, static_cast<const int32_t*>(v.data), b, e, range);
    case ScalarType::UInt32: return compareRange(decoded, static_cast<const uint32_t*>(v.data), b, e, range);
    case ScalarType::Int64: return compareRange(decoded, static_cast<const int64_t*>(v.data), b, e, range);
    case ScalarType::UInt64: return compareRange(decoded, static_cast<const uint64_t*>(v.data), b, e, range);
    case ScalarType::Float32: return compareRange(decoded, static_cast<const float*>(v.data), b, e, range);
    case ScalarType::Float64: return compareRange(decoded, static_cast<const double*>(v.data), b, e, range);
  }
  return CompareSums();
}

template <typename T>
ErrorStats compareDecodedT(const T* decoded, const VolumeView& v, double valueMin, double valueMax, int threads)
{
  ErrorStats r;
  const ValueRange range(valueMin, valueMax);
  ThreadPool pool(threads);
  std::vector<CompareSums> parts(static_cast<size_t>(pool.size()));
  pool.parallelFor(v.count(), [&](int64_t b, int64_t e, int w) {
    parts[static_cast<size_t>(w)] = compareRangeOf(decoded, v, b, e, range);
  });
  double sum = 0.0;
  for (const CompareSums& part : parts)
  {
    sum += part.squared;
    r.maxAbsError = std::max(r.maxAbsError, part.maxAbs);
    r.maxErrorOfRange = std::max(r.maxErrorOfRange, part.maxOfRange);
    r.count += part.count;
    r.nonFinite += part.bad;
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
