// NeuralVolume engine: the domain mask of a resampled source (SourceInfo::domain) -- one bit per source sample,
// x fastest, 1 = inside the source's cells -- looked up at the nearest sample of a normalised point. Host-device code:
// the renderers of both backends and the host API compute the same function.
#pragma once

#include "HostDevice.h"

#include <cstdint>

namespace nv
{

/// Bit of the source sample nearest to the normalised point u (in [0,1]^3, clamped) in a mask of dims samples.
NV_HD bool domainBit(const uint32_t* bits, const int dims[3], float u0, float u1, float u2)
{
  const float u[3] = { u0, u1, u2 };
  int64_t idx = 0, stride = 1;
  for (int a = 0; a < 3; ++a)
  {
    const int n = dims[a];
    int i = static_cast<int>(u[a] * static_cast<float>(n - 1) + 0.5f);
    i = i < 0 ? 0 : (i > n - 1 ? n - 1 : i);
    idx += static_cast<int64_t>(i) * stride;
    stride *= n;
  }
  return ((bits[idx >> 5] >> (idx & 31)) & 1u) != 0u;
}

} // namespace nv
