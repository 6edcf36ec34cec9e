// NeuralVolume engine: trilinear lookup in a grid of normalised values over [0,1]^3 (sample i at i/(n-1), the
// convention of decodeGrid), for the Decode render path and the macrocell margin.
#pragma once

#include "Core/Volume.h"

#include <cstdint>
#include <limits>

namespace nv
{

class CpuGridSampler
{
public:
  /// values: dims[0] x dims[1] x dims[2], x fastest. nanAware: NaN samples are left out and the remaining weights
  /// renormalised (as the training sampler does); NaN only where every corner is NaN.
  CpuGridSampler(const float* values, const int64_t dims[3], bool nanAware)
    : Values(values)
    , NanAware(nanAware)
  {
    for (int a = 0; a < 3; ++a)
    {
      Dims[a] = dims[a];
      MaxIndex[a] = dims[a] > 1 ? static_cast<float>(dims[a] - 1) : 0.0f;
    }
    Step[0] = dims[0] > 1 ? 1 : 0;
    Step[1] = dims[1] > 1 ? dims[0] : 0;
    Step[2] = dims[2] > 1 ? dims[0] * dims[1] : 0;
  }

  /// Value at u in [0,1]^3 (clamped).
  float operator()(const float u[3]) const
  {
    if (NanAware)
      return nanAware(u);
    int64_t base = 0;
    float f[3];
    const int64_t stride[3] = { 1, Dims[0], Dims[0] * Dims[1] };
    for (int a = 0; a < 3; ++a)
    {
      float p = u[a] * MaxIndex[a];
      p = p > 0.0f ? p : 0.0f; // also maps NaN to 0
      int64_t i = static_cast<int64_t>(p);
      const int64_t last = Dims[a] > 1 ? Dims[a] - 2 : 0;
      i = i < last ? i : last;
      f[a] = p - static_cast<float>(i);
      f[a] = f[a] < 1.0f ? f[a] : 1.0f;
      base += i * stride[a];
    }
    const float* c = Values + base;
    const int64_t dx = Step[0], dy = Step[1], dz = Step[2];
    const float x00 = c[0] + f[0] * (c[dx] - c[0]);
    const float x10 = c[dy] + f[0] * (c[dy + dx] - c[dy]);
    const float x01 = c[dz] + f[0] * (c[dz + dx] - c[dz]);
    const float x11 = c[dz + dy] + f[0] * (c[dz + dy + dx] - c[dz + dy]);
    const float y0 = x00 + f[1] * (x10 - x00), y1 = x01 + f[1] * (x11 - x01);
    return y0 + f[2] * (y1 - y0);
  }

private:
  float nanAware(const float u[3]) const
  {
    const float* v = Values;
    float out;
    if (!sampleTrilinear([v](int64_t i) { return v[i]; }, Dims, 0.0f, 1.0f, u, out))
      return std::numeric_limits<float>::quiet_NaN();
    return out;
  }

  const float* Values;
  int64_t Dims[3];
  float MaxIndex[3]; ///< dims - 1 per axis (0 where dims is 1): [0,1] to sample index
  int64_t Step[3];   ///< index step to the next sample per axis (0 where dims is 1)
  bool NanAware;
};

} // namespace nv
