// NeuralVolume engine: a read-only view of a source scalar volume in its native type.
#pragma once

#include "HostDevice.h"

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace nv
{

enum class ScalarType : int
{
  Int8,
  UInt8,
  Int16,
  UInt16,
  Int32,
  UInt32,
  Int64,
  UInt64,
  Float32,
  Float64
};

size_t scalarSize(ScalarType t);
const char* scalarTypeName(ScalarType t);

/// A single-component volume, x fastest, contiguous. Values are normalised by
/// (v - valueMin) / (valueMax - valueMin) (nv::ValueRange: also when that width overflows); non-finite samples are
/// "invalid" and never trained on.
struct VolumeView
{
  const void* data = nullptr;
  ScalarType type = ScalarType::Float32;
  int64_t dims[3] = { 1, 1, 1 };
  double valueMin = 0.0;
  double valueMax = 1.0;

  int64_t count() const { return dims[0] * dims[1] * dims[2]; }
  int64_t bytes() const { return count() * static_cast<int64_t>(scalarSize(type)); }
  double at(int64_t i) const;
};

/// Range and invalid count of a volume (non-finite values are skipped).
struct VolumeStats
{
  double min = 0.0;
  double max = 0.0;
  int64_t invalid = 0;
  int64_t valid = 0;
};
VolumeStats computeStats(const VolumeView& v);

NV_HD bool finiteValue(float v)
{
#if defined(__CUDA_ARCH__)
  return isfinite(v);
#else
  return std::isfinite(v);
#endif
}

/// Trilinear interpolation of normalised values at x in [0,1]^3 (voxel i at i/(n-1)), typed accessor `get`.
/// Corners that are not finite are left out and the remaining weights renormalised; returns false when
/// every corner is invalid. Shared by the CPU sampler and the CUDA kernels.
template <typename Getter>
NV_HD bool sampleTrilinear(const Getter& get, const int64_t dims[3], float shift, float invRange, const float x[3],
  float& out)
{
  int64_t i0[3];
  float f[3];
  for (int d = 0; d < 3; ++d)
  {
    const int64_t n = dims[d];
    if (n <= 1)
    {
      i0[d] = 0;
      f[d] = 0.0f;
      continue;
    }
    float p = x[d] * static_cast<float>(n - 1);
    p = p < 0.0f ? 0.0f : p;
    int64_t i = static_cast<int64_t>(p);
    if (i > n - 2)
    {
      i = n - 2;
    }
    i0[d] = i;
    f[d] = p - static_cast<float>(i);
    f[d] = f[d] > 1.0f ? 1.0f : f[d];
  }
  float acc = 0.0f;
  float wsum = 0.0f;
  for (int c = 0; c < 8; ++c)
  {
    const int64_t cx = i0[0] + ((c & 1) && dims[0] > 1 ? 1 : 0);
    const int64_t cy = i0[1] + ((c & 2) && dims[1] > 1 ? 1 : 0);
    const int64_t cz = i0[2] + ((c & 4) && dims[2] > 1 ? 1 : 0);
    const float w = ((c & 1) ? f[0] : 1.0f - f[0]) * ((c & 2) ? f[1] : 1.0f - f[1]) * ((c & 4) ? f[2] : 1.0f - f[2]);
    if (w == 0.0f)
    {
      continue;
    }
    const float v = get((cz * dims[1] + cy) * dims[0] + cx);
    if (finiteValue(v))
    {
      acc += w * (v - shift);
      wsum += w;
    }
  }
  if (!(wsum > 0.0f))
  {
    return false;
  }
  out = acc * invRange / wsum;
  return true;
}

} // namespace nv
