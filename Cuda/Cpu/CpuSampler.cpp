#include "CpuSampler.h"

#include "Core/ValueRange.h"

namespace nv
{
namespace
{
template <typename T>
int64_t sampleT(const VolumeView& v, const float* xyz, int64_t n, float* targets, uint8_t* valid)
{
  const T* data = static_cast<const T*>(v.data);
  // Normalise in double so huge ranges (e.g. 1e300, or wider than the largest double) stay finite in float.
  const ValueRange range(v.valueMin, v.valueMax);
  auto get = [&](int64_t i) { return static_cast<float>(range.normalize(static_cast<double>(data[i]))); };
  int64_t count = 0;
  for (int64_t s = 0; s < n; ++s)
  {
    float t = 0.0f;
    const bool ok = sampleTrilinear(get, v.dims, 0.0f, 1.0f, xyz + 3 * s, t);
    targets[s] = ok ? t : 0.0f;
    valid[s] = ok ? 1 : 0;
    count += ok ? 1 : 0;
  }
  return count;
}
} // namespace

int64_t sampleTargets(const VolumeView& v, const float* xyz, int64_t n, float* targets, uint8_t* valid)
{
  switch (v.type)
  {
    case ScalarType::Int8:
      return sampleT<int8_t>(v, xyz, n, targets, valid);
    case ScalarType::UInt8:
      return sampleT<uint8_t>(v, xyz, n, targets, valid);
    case ScalarType::Int16:
      return sampleT<int16_t>(v, xyz, n, targets, valid);
    case ScalarType::UInt16:
      return sampleT<uint16_t>(v, xyz, n, targets, valid);
    case ScalarType::Int32:
      return sampleT<int32_t>(v, xyz, n, targets, valid);
    case ScalarType::UInt32:
      return sampleT<uint32_t>(v, xyz, n, targets, valid);
    case ScalarType::Int64:
      return sampleT<int64_t>(v, xyz, n, targets, valid);
    case ScalarType::UInt64:
      return sampleT<uint64_t>(v, xyz, n, targets, valid);
    case ScalarType::Float32:
      return sampleT<float>(v, xyz, n, targets, valid);
    case ScalarType::Float64:
      return sampleT<double>(v, xyz, n, targets, valid);
  }
  return 0;
}

} // namespace nv
