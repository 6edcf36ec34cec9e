// NeuralVolume engine: macrocells -- the value range of the field per block of voxels and, combined with the
// current transfer function, the largest extinction per block (its majorant; 0 = empty space). Host-device code: the
// CPU backend loops over cells, the CUDA backend runs one thread per cell; both compute the same numbers.
//
// Cells are kCellVoxels source voxels wide: cell index along an axis = floor(u * scale) with
// scale = (n - 1) / kCellVoxels, where u in [0,1] is the network coordinate and n the source's samples on the axis.
// Ranges come from a lattice of field values (sample i at i / (L - 1)): a cell takes every lattice sample inside it
// and one more on each side (trilinear interpolation between lattice samples stays inside that hull), widened by a
// margin for what the network does between lattice samples.
#pragma once

#include "HostDevice.h"

#include <cstdint>

namespace nv
{

constexpr int kCellVoxels = 8;
/// Network paths: the lattice of network values has the source's resolution, at most this many samples per axis.
constexpr int64_t kMaxLatticeSamples = 256;
/// Network paths: normalised margin added to each cell's lattice range for what the network does between lattice
/// samples (the Decode path's grid needs none: trilinear interpolation stays inside the hull).
constexpr float kNetworkRangeMargin = 0.02f;

struct MacrocellLayout
{
  int dims[3];    ///< cells per axis
  float scale[3]; ///< cell index = floor(u * scale)
};

/// Layout for a source of n[a] samples per axis.
NV_HD MacrocellLayout macrocellLayout(const int64_t n[3])
{
  MacrocellLayout m{};
  for (int a = 0; a < 3; ++a)
  {
    const int64_t span = n[a] > 1 ? n[a] - 1 : 1;
    const int64_t cells = (span + kCellVoxels - 1) / kCellVoxels;
    m.dims[a] = static_cast<int>(cells < 1 ? 1 : cells);
    m.scale[a] = n[a] > 1 ? static_cast<float>(static_cast<double>(span) / kCellVoxels) : 1.0f;
  }
  return m;
}

/// Bit of the cell holding normalised point u in an occupancy mask over layout m's cells (SourceInfo::occupancy).
NV_HD bool cellOccupied(const uint32_t* bits, const MacrocellLayout& m, float u0, float u1, float u2)
{
  const float u[3] = { u0, u1, u2 };
  int64_t idx = 0, stride = 1;
  for (int a = 0; a < 3; ++a)
  {
    int c = static_cast<int>(u[a] * m.scale[a]);
    c = c < 0 ? 0 : (c > m.dims[a] - 1 ? m.dims[a] - 1 : c);
    idx += static_cast<int64_t>(c) * stride;
    stride *= m.dims[a];
  }
  return ((bits[idx >> 5] >> (idx & 31)) & 1u) != 0u;
}

/// Cell c (x fastest) of an occupancy mask.
NV_HD bool cellBit(const uint32_t* bits, int64_t c)
{
  return ((bits[c >> 5] >> (c & 31)) & 1u) != 0u;
}

/// Normalised value range [lo, hi] of cell (cx, cy, cz) from a lattice of L[a] samples per axis (x fastest), NaN
/// samples ignored; lo > hi when every sample is NaN.
NV_HD void cellRange(const MacrocellLayout& m, const float* lattice, const int64_t L[3], int cx, int cy, int cz,
  float margin, float& lo, float& hi)
{
  const int c[3] = { cx, cy, cz };
  int64_t b[3], e[3];
  for (int a = 0; a < 3; ++a)
  {
    if (L[a] <= 1)
    {
      b[a] = 0;
      e[a] = 0;
      continue;
    }
    const double s = static_cast<double>(L[a] - 1);
    const double u0 = static_cast<double>(c[a]) / m.scale[a], u1 = static_cast<double>(c[a] + 1) / m.scale[a];
    int64_t i0 = static_cast<int64_t>(u0 * s) - 1, i1 = static_cast<int64_t>(u1 * s + 0.999999) + 1;
    b[a] = i0 < 0 ? 0 : i0;
    e[a] = i1 > L[a] - 1 ? L[a] - 1 : i1;
  }
  lo = 3.0e38f;
  hi = -3.0e38f;
  for (int64_t z = b[2]; z <= e[2]; ++z)
    for (int64_t y = b[1]; y <= e[1]; ++y)
    {
      const float* row = lattice + (z * L[1] + y) * L[0];
      for (int64_t x = b[0]; x <= e[0]; ++x)
      {
        const float v = row[x];
        if (!(v == v))
          continue;
        lo = v < lo ? v : lo;
        hi = v > hi ? v : hi;
      }
    }
  if (lo <= hi)
  {
    lo -= margin;
    hi += margin;
  }
}

/// Largest extinction of a transfer-function table (entries r, g, b, extinction; entry coordinate of value y is
/// y * scale + shift, clamped, linear between entries) over the values [lo, hi]; 0 when lo > hi.
NV_HD float rangeMajorant(const float* tf, int size, float scale, float shift, float lo, float hi)
{
  if (!(lo <= hi))
    return 0.0f;
  const float last = static_cast<float>(size - 1);
  float c0 = lo * scale + shift, c1 = hi * scale + shift;
  if (c0 > c1)
  {
    const float s = c0;
    c0 = c1;
    c1 = s;
  }
  c0 = c0 < 0.0f ? 0.0f : (c0 > last ? last : c0);
  c1 = c1 < 0.0f ? 0.0f : (c1 > last ? last : c1);
  auto at = [&](float c) {
    int i = static_cast<int>(c);
    i = i > size - 2 ? size - 2 : i;
    const float f = c - static_cast<float>(i);
    return tf[4 * i + 3] + f * (tf[4 * i + 7] - tf[4 * i + 3]);
  };
  float m = at(c0);
  const float e1 = at(c1);
  m = e1 > m ? e1 : m;
  for (int i = static_cast<int>(c0) + 1; i <= static_cast<int>(c1); ++i)
    m = tf[4 * i + 3] > m ? tf[4 * i + 3] : m;
  return m;
}

} // namespace nv
