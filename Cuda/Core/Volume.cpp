#include "Volume.h"

#include "Error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <system_error>
#include <thread>
#include <type_traits>
#include <vector>

namespace nv
{

size_t scalarSize(ScalarType t)
{
  switch (t)
  {
    case ScalarType::Int8:
    case ScalarType::UInt8:
      return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16:
      return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32:
      return 4;
    case ScalarType::Int64:
    case ScalarType::UInt64:
    case ScalarType::Float64:
      return 8;
  }
  return 0;
}

const char* scalarTypeName(ScalarType t)
{
  static const char* names[] = { "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "float32",
    "float64" };
  return names[static_cast<int>(t)];
}

double VolumeView::at(int64_t i) const
{
  switch (type)
  {
    case ScalarType::Int8:
      return static_cast<const int8_t*>(data)[i];
    case ScalarType::UInt8:
      return static_cast<const uint8_t*>(data)[i];
    case ScalarType::Int16:
      return static_cast<const int16_t*>(data)[i];
    case ScalarType::UInt16:
      return static_cast<const uint16_t*>(data)[i];
    case ScalarType::Int32:
      return static_cast<const int32_t*>(data)[i];
    case ScalarType::UInt32:
      return static_cast<const uint32_t*>(data)[i];
    case ScalarType::Int64:
      return static_cast<double>(static_cast<const int64_t*>(data)[i]);
    case ScalarType::UInt64:
      return static_cast<double>(static_cast<const uint64_t*>(data)[i]);
    case ScalarType::Float32:
      return static_cast<const float*>(data)[i];
    case ScalarType::Float64:
      return static_cast<const double*>(data)[i];
  }
  return std::numeric_limits<double>::quiet_NaN();
}

namespace
{
/// Stats of values [b, e) of one type: a typed loop (no per-value type switch), min / max in the value's own type.
template <typename T>
VolumeStats typedStats(const T* p, int64_t b, int64_t e)
{
  VolumeStats s;
  int64_t valid = 0;
  if constexpr (std::is_floating_point<T>::value)
  {
    T lo = std::numeric_limits<T>::infinity(), hi = -std::numeric_limits<T>::infinity();
    for (int64_t i = b; i < e; ++i)
    {
      const T x = p[i];
      const bool ok = std::isfinite(x);
      valid += ok ? 1 : 0;
      lo = ok && x < lo ? x : lo;
      hi = ok && x > hi ? x : hi;
    }
    s.min = static_cast<double>(lo);
    s.max = static_cast<double>(hi);
  }
  else
  {
    T lo = std::numeric_limits<T>::max(), hi = std::numeric_limits<T>::lowest();
    for (int64_t i = b; i < e; ++i)
    {
      const T x = p[i];
      lo = x < lo ? x : lo;
      hi = x > hi ? x : hi;
    }
    valid = e - b;
    s.min = e > b ? static_cast<double>(lo) : std::numeric_limits<double>::infinity();
    s.max = e > b ? static_cast<double>(hi) : -std::numeric_limits<double>::infinity();
  }
  s.valid = valid;
  s.invalid = (e - b) - valid;
  return s;
}

VolumeStats rangeStats(const VolumeView& v, int64_t b, int64_t e)
{
  switch (v.type)
  {
    case ScalarType::Int8:
      return typedStats(static_cast<const int8_t*>(v.data), b, e);
    case ScalarType::UInt8:
      return typedStats(static_cast<const uint8_t*>(v.data), b, e);
    case ScalarType::Int16:
      return typedStats(static_cast<const int16_t*>(v.data), b, e);
    case ScalarType::UInt16:
      return typedStats(static_cast<const uint16_t*>(v.data), b, e);
    case ScalarType::Int32:
      return typedStats(static_cast<const int32_t*>(v.data), b, e);
    case ScalarType::UInt32:
      return typedStats(static_cast<const uint32_t*>(v.data), b, e);
    case ScalarType::Int64:
      return typedStats(static_cast<const int64_t*>(v.data), b, e);
    case ScalarType::UInt64:
      return typedStats(static_cast<const uint64_t*>(v.data), b, e);
    case ScalarType::Float32:
      return typedStats(static_cast<const float*>(v.data), b, e);
    case ScalarType::Float64:
      return typedStats(static_cast<const double*>(v.data), b, e);
  }
  NV_THROW("unknown scalar type");
}
} // namespace

VolumeStats computeStats(const VolumeView& v)
{
  NV_CHECK(v.data != nullptr || v.count() == 0, "volume has no data");
  const int64_t n = v.count();
  // Large volumes (a 256^3 field when a state is loaded) on several threads: the result does not depend on the split
  // (min, max and counts are exact).
  const int64_t perThread = int64_t(1) << 22;
  const int parts = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(
    std::min<int64_t>(8, std::max<unsigned>(1u, std::thread::hardware_concurrency())), n / perThread)));
  std::vector<VolumeStats> partial(static_cast<size_t>(parts));
  std::vector<std::thread> threads;
  for (int t = 1; t < parts; ++t)
  {
    auto part = [&, t] { partial[size_t(t)] = rangeStats(v, n * t / parts, n * (t + 1) / parts); };
    try
    {
      threads.emplace_back(part);
    }
    catch (const std::system_error&) // no thread to be had (a process limit): this part in this thread
    {
      part();
    }
  }
  partial[0] = rangeStats(v, 0, n / parts);
  for (std::thread& t : threads)
    t.join();
  VolumeStats s;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -std::numeric_limits<double>::infinity();
  for (const VolumeStats& p : partial)
  {
    s.valid += p.valid;
    s.invalid += p.invalid;
    if (p.valid > 0)
    {
      s.min = std::min(s.min, p.min);
      s.max = std::max(s.max, p.max);
    }
  }
  if (s.valid == 0)
  {
    s.min = s.max = 0.0;
  }
  return s;
}

} // namespace nv
