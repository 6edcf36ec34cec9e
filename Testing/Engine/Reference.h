// Independent double-precision reference of the model for the engine tests: written from the method's
// definition (tiny-cuda-nn conventions), not from the engine's code paths.
#pragma once

#include "Core/Model.h"

#include <cmath>
#include <cstdint>
#include <vector>

namespace nvtest
{

struct RefLevel
{
  double scale;
  uint64_t res, entries, offset;
  bool hashed;
};

/// Levels from the configuration, computed with 64-bit integers (the scale in float as the method specifies).
inline std::vector<RefLevel> refLevels(const nv::EncodingConfig& e)
{
  std::vector<RefLevel> out;
  const double pls = e.perLevelScale > 0 ? e.perLevelScale
                                         : (e.levels > 1 ? std::pow(double(e.finestResolution) / e.baseResolution,
                                                             1.0 / (e.levels - 1))
                                                         : 1.0);
  const float log2pls = std::log2(float(pls));
  uint64_t off = 0;
  const uint64_t T = 1ull << e.log2TableSize;
  for (int l = 0; l < e.levels; ++l)
  {
    RefLevel r;
    r.scale = double(std::exp2(float(l) * log2pls) * float(e.baseResolution) - 1.0f);
    r.res = uint64_t(std::ceil(r.scale)) + 1;
    const uint64_t dense = r.res * r.res * r.res;
    const uint64_t padded = (dense + 7) / 8 * 8;
    r.hashed = padded > T || r.res > 1625;
    r.entries = r.hashed ? T : padded;
    r.offset = off;
    off += r.entries;
    out.push_back(r);
  }
  return out;
}

inline uint64_t refIndex(const RefLevel& r, uint64_t x, uint64_t y, uint64_t z)
{
  uint64_t i;
  if (r.hashed)
    i = ((x * 1ull) ^ (y * 2654435761ull) ^ (z * 805459861ull)) & 0xFFFFFFFFull;
  else
    i = x + y * r.res + z * r.res * r.res;
  return r.offset + i % r.entries;
}

/// Encoding of one point in double precision.
inline std::vector<double> refEncode(const nv::Model& m, const std::vector<double>& table, const double x[3])
{
  const auto lv = refLevels(m.config().encoding);
  const int F = m.config().encoding.featuresPerLevel;
  std::vector<double> out(lv.size() * F, 0.0);
  for (size_t l = 0; l < lv.size(); ++l)
  {
    double p[3], f[3];
    uint64_t c[3];
    for (int d = 0; d < 3; ++d)
    {
      p[d] = double(float(x[d]) * float(lv[l].scale) + 0.5f); // position in float as the method does
      c[d] = uint64_t(std::floor(p[d]));
      f[d] = p[d] - std::floor(p[d]);
    }
    for (int k = 0; k < 8; ++k)
    {
      const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
      const double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
      const uint64_t idx = refIndex(lv[l], c[0] + dx, c[1] + dy, c[2] + dz);
      for (int j = 0; j < F; ++j)
        out[l * F + j] += w * table[idx * F + j];
    }
  }
  return out;
}

/// Full model output in double precision; params as doubles in the engine's layout.
inline double refForward(const nv::Model& m, const std::vector<double>& params, const double x[3])
{
  std::vector<double> h = refEncode(m, params, x);
  const int H = m.config().network.hiddenLayers;
  for (int l = 0; l <= H; ++l)
  {
    const int in = m.layerInputs(l), out = m.layerOutputs(l);
    const double* W = params.data() + m.layerOffset(l);
    std::vector<double> y(out, 0.0);
    for (int o = 0; o < out; ++o)
    {
      for (int i = 0; i < in; ++i)
        y[o] += W[size_t(o) * in + i] * h[i];
      if (l < H)
        y[o] = y[o] > 0 ? y[o] : 0;
    }
    h.swap(y);
  }
  return h[0];
}

} // namespace nvtest
