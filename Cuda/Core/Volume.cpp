#include "Volume.h"

#include "Error.h"

#include <cmath>
#include <limits>

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

VolumeStats computeStats(const VolumeView& v)
{
  NV_CHECK(v.data != nullptr || v.count() == 0, "volume has no data");
  VolumeStats s;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -std::numeric_limits<double>::infinity();
  const int64_t n = v.count();
  for (int64_t i = 0; i < n; ++i)
  {
    const double x = v.at(i);
    if (!std::isfinite(x))
    {
      ++s.invalid;
      continue;
    }
    ++s.valid;
    s.min = x < s.min ? x : s.min;
    s.max = x > s.max ? x : s.max;
  }
  if (s.valid == 0)
  {
    s.min = s.max = 0.0;
  }
  return s;
}

} // namespace nv
