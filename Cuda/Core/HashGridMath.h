// NeuralVolume engine: hash-grid math shared by the CPU and CUDA implementations.
//
// Conventions follow tiny-cuda-nn, so a model trained here computes the same function as the reference:
//   scale_l = 2^(l * log2(perLevelScale)) * base - 1   (float32)
//   res_l   = ceil(scale_l) + 1
//   entries = min(roundUp8(res_l^3), 2^log2T); a level is hashed when entries < res_l^3
//   pos     = x * scale_l + 0.5, corner = floor(pos), weights = trilinear in frac(pos)
//   dense index  = c0 + c1*res + c2*res^2 (mod entries)
//   hashed index = (c0 * 1) ^ (c1 * 2654435761) ^ (c2 * 805459861) (uint32, mod entries)
#pragma once

#include "HostDevice.h"

#include <cmath>
#include <cstdint>

namespace nv
{

constexpr int kMaxLevels = 32;
constexpr int kMaxFeatures = 8;

struct LevelInfo
{
  float scale;      ///< scale_l above
  uint32_t res;     ///< grid vertices per axis
  uint32_t entries; ///< table entries of this level
  uint32_t offset;  ///< first entry of this level in the table
  uint32_t hashed;  ///< 1 when the spatial hash is used
};

/// Level table of an encoding; plain data, copyable to the GPU by value.
struct GridLayout
{
  int levels;
  int features;
  uint32_t totalEntries;
  LevelInfo level[kMaxLevels];
};

/// The spatial hash of a hashed level's vertex (before the modulo of its entries); the one definition both backends
/// use.
NV_HD uint32_t spatialHash(uint32_t c0, uint32_t c1, uint32_t c2)
{
  return (c0 * 1u) ^ (c1 * 2654435761u) ^ (c2 * 805459861u);
}

NV_HD uint32_t gridIndex(const LevelInfo& lv, uint32_t c0, uint32_t c1, uint32_t c2)
{
  uint32_t idx;
  if (lv.hashed)
  {
    idx = spatialHash(c0, c1, c2);
  }
  else
  {
    idx = c0 + c1 * lv.res + c2 * lv.res * lv.res;
  }
  return lv.offset + idx % lv.entries;
}

/// Corner and fractional position of point x (each coordinate in [0,1]) on a level.
NV_HD void gridPosition(const LevelInfo& lv, const float x[3], uint32_t corner[3], float frac[3])
{
  for (int d = 0; d < 3; ++d)
  {
    const float p = x[d] * lv.scale + 0.5f;
    const float f = floorf(p);
    corner[d] = static_cast<uint32_t>(static_cast<int>(f));
    frac[d] = p - f;
  }
}

/// Trilinear weight of corner c (bit d of c = offset along axis d).
NV_HD float cornerWeight(int c, const float frac[3])
{
  const float w0 = (c & 1) ? frac[0] : 1.0f - frac[0];
  const float w1 = (c & 2) ? frac[1] : 1.0f - frac[1];
  const float w2 = (c & 4) ? frac[2] : 1.0f - frac[2];
  return w0 * w1 * w2;
}

NV_HD uint32_t cornerIndex(const LevelInfo& lv, int c, const uint32_t corner[3])
{
  return gridIndex(lv, corner[0] + (c & 1), corner[1] + ((c >> 1) & 1), corner[2] + ((c >> 2) & 1));
}

/// 64-bit mixing (splitmix64 finaliser): counter-based random numbers, identical on CPU and GPU.
NV_HD uint64_t mix64(uint64_t z)
{
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// Uniform training coordinate in [0,1)^3 for sample `index` of step `step` (independent of threads/launch shape).
NV_HD void randomPoint(uint64_t seed, uint64_t step, uint64_t index, float x[3])
{
  const uint64_t a = mix64(seed ^ mix64(step * 0x100000001B3ull + 0x51ED27ull) ^ (index * 0xD6E8FEB86659FD93ull));
  const uint64_t b = mix64(a ^ 0xA0761D6478BD642Full);
  const float inv = 1.0f / 16777216.0f; // 24-bit mantissa
  x[0] = static_cast<float>(static_cast<uint32_t>(a >> 40)) * inv;
  x[1] = static_cast<float>(static_cast<uint32_t>((a >> 16) & 0xFFFFFFu)) * inv;
  x[2] = static_cast<float>(static_cast<uint32_t>(b >> 40)) * inv;
}

} // namespace nv
