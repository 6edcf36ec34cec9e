#include "CpuHashGrid.h"

#include <algorithm>
#include <cstring>

namespace nv
{
namespace
{

// The table of a fine level is far larger than the caches, so a sample's eight corners are mostly cache misses.
// Both passes work on small blocks of samples in a pipeline: the corner indices and weights of the block `kDepth`
// blocks ahead are computed (and their table lines prefetched) before the current block's entries are used, so many
// misses are in flight at once instead of one sample's. The arithmetic and its order are those of HashGridMath.h.
constexpr int kBlock = 8;
constexpr int kDepth = 2;

/// A level's index (gridIndex of HashGridMath.h) without a division in the common cases: a hashed level has 2^k
/// entries (it is hashed because its grid outgrew the 2^log2T table), and a dense level's index reaches past its
/// entries only for the corners one step beyond the grid.
struct FastLevel
{
  uint32_t res = 0;
  uint32_t res2 = 0;
  uint32_t offset = 0;
  uint32_t entries = 1;
  uint32_t mask = 0; ///< entries - 1 when entries is a power of two
  bool pow2 = true;
  bool hashed = false;

  FastLevel() = default;
  explicit FastLevel(const LevelInfo& lv)
    : res(lv.res)
    , res2(lv.res * lv.res)
    , offset(lv.offset)
    , entries(lv.entries)
    , mask(lv.entries - 1)
    , pow2((lv.entries & (lv.entries - 1)) == 0)
    , hashed(lv.hashed != 0)
  {
  }

  uint32_t index(uint32_t c0, uint32_t c1, uint32_t c2) const
  {
    if (hashed)
    {
      const uint32_t h = spatialHash(c0, c1, c2);
      return offset + (pow2 ? h & mask : h % entries);
    }
    const uint32_t idx = c0 + c1 * res + c2 * res2;
    return offset + (idx < entries ? idx : idx % entries);
  }
};

struct Corners
{
  uint32_t idx[8];
  float weights[8];
};

/// Corners of sample x on a level; prefetches their entries (for writing when `forWrite`).
template <int F, bool forWrite>
inline void corners(const LevelInfo& lv, const FastLevel& fl, const float* x, const float* table, Corners& k)
{
  uint32_t corner[3];
  float frac[3];
  gridPosition(lv, x, corner, frac);
  for (int c = 0; c < 8; ++c)
  {
    k.idx[c] = fl.index(corner[0] + (c & 1), corner[1] + ((c >> 1) & 1), corner[2] + ((c >> 2) & 1));
    k.weights[c] = cornerWeight(c, frac);
    __builtin_prefetch(table + static_cast<size_t>(k.idx[c]) * F, forWrite ? 1 : 0, 3);
  }
}

template <int F>
void encodeT(const GridLayout& g, const float* table, const float* xyz, int64_t n, float* out)
{
  const int L = g.levels;
  const int stride = L * F;
  FastLevel fl[kMaxLevels];
  for (int l = 0; l < L; ++l)
  {
    fl[l] = FastLevel(g.level[l]);
  }
  // Work units: (block of samples, level), blocks outer.
  const int64_t blocks = (n + kBlock - 1) / kBlock;
  const int64_t units = blocks * L;
  Corners ring[kDepth + 1][kBlock];
  auto prepare = [&](int64_t u) {
    const int64_t b = u / L;
    const int l = static_cast<int>(u - b * L);
    const int64_t s0 = b * kBlock;
    const int m = static_cast<int>(std::min<int64_t>(kBlock, n - s0));
    Corners* k = ring[u % (kDepth + 1)];
    for (int s = 0; s < m; ++s)
    {
      corners<F, false>(g.level[l], fl[l], xyz + 3 * (s0 + s), table, k[s]);
    }
  };
  for (int64_t u = 0; u < std::min<int64_t>(kDepth, units); ++u)
  {
    prepare(u);
  }
  for (int64_t u = 0; u < units; ++u)
  {
    if (u + kDepth < units)
    {
      prepare(u + kDepth);
    }
    const int64_t b = u / L;
    const int l = static_cast<int>(u - b * L);
    const int64_t s0 = b * kBlock;
    const int m = static_cast<int>(std::min<int64_t>(kBlock, n - s0));
    const Corners* k = ring[u % (kDepth + 1)];
    for (int s = 0; s < m; ++s)
    {
      float acc[F] = {};
      for (int c = 0; c < 8; ++c)
      {
        const float w = k[s].weights[c];
        const float* e = table + static_cast<size_t>(k[s].idx[c]) * F;
        for (int f = 0; f < F; ++f)
        {
          acc[f] += w * e[f];
        }
      }
      float* o = out + (s0 + s) * stride + l * F;
      for (int f = 0; f < F; ++f)
      {
        o[f] = acc[f];
      }
    }
  }
}

/// e[f] += w * d[f], four features per vector instruction where F allows.
template <int F>
inline void addScaled(float* e, float w, const float* d)
{
  if (F % 4 == 0)
  {
    typedef float V4 __attribute__((vector_size(16)));
    for (int f = 0; f < F; f += 4)
    {
      V4 ev, dv;
      std::memcpy(&ev, e + f, sizeof ev);
      std::memcpy(&dv, d + f, sizeof dv);
      ev += (V4{} + w) * dv;
      std::memcpy(e + f, &ev, sizeof ev);
    }
    return;
  }
  for (int f = 0; f < F; ++f)
  {
    e[f] += w * d[f];
  }
}

template <int F>
void backwardT(const GridLayout& g, const float* xyz, int64_t n, const float* dOut, float* grad, int l0, int l1)
{
  const int stride = g.levels * F;
  const int64_t blocks = (n + kBlock - 1) / kBlock;
  Corners ring[kDepth + 1][kBlock];
  bool live[kDepth + 1][kBlock];
  for (int l = l0; l < l1; ++l)
  {
    const LevelInfo& lv = g.level[l];
    const FastLevel fl(lv);
    auto prepare = [&](int64_t b) {
      const int64_t s0 = b * kBlock;
      const int m = static_cast<int>(std::min<int64_t>(kBlock, n - s0));
      const int slot = static_cast<int>(b % (kDepth + 1));
      // The gradients of the samples one pipeline further on (a strided walk through dOut).
      for (int64_t s = s0 + kDepth * kBlock; s < std::min<int64_t>(n, s0 + (kDepth + 1) * kBlock); ++s)
      {
        __builtin_prefetch(dOut + s * stride + l * F, 0, 3);
      }
      for (int s = 0; s < m; ++s)
      {
        const float* d = dOut + (s0 + s) * stride + l * F;
        bool any = false;
        for (int f = 0; f < F; ++f)
        {
          any |= d[f] != 0.0f;
        }
        live[slot][s] = any;
        if (any)
        {
          corners<F, true>(lv, fl, xyz + 3 * (s0 + s), grad, ring[slot][s]);
        }
      }
    };
    for (int64_t b = 0; b < std::min<int64_t>(kDepth, blocks); ++b)
    {
      prepare(b);
    }
    for (int64_t b = 0; b < blocks; ++b)
    {
      if (b + kDepth < blocks)
      {
        prepare(b + kDepth);
      }
      const int64_t s0 = b * kBlock;
      const int m = static_cast<int>(std::min<int64_t>(kBlock, n - s0));
      const int slot = static_cast<int>(b % (kDepth + 1));
      for (int s = 0; s < m; ++s)
      {
        if (!live[slot][s])
        {
          continue;
        }
        float d[F]; // a local copy: the compiler need not assume that the scatter changes it
        for (int f = 0; f < F; ++f)
        {
          d[f] = dOut[(s0 + s) * stride + l * F + f];
        }
        const Corners& k = ring[slot][s];
        for (int c = 0; c < 8; ++c)
        {
          addScaled<F>(grad + static_cast<size_t>(k.idx[c]) * F, k.weights[c], d);
        }
      }
    }
  }
}

} // namespace

void CpuHashGrid::encode(const GridLayout& g, const float* table, const float* xyz, int64_t n, float* out)
{
  switch (g.features)
  {
    case 1:
      return encodeT<1>(g, table, xyz, n, out);
    case 2:
      return encodeT<2>(g, table, xyz, n, out);
    case 4:
      return encodeT<4>(g, table, xyz, n, out);
    default:
      return encodeT<8>(g, table, xyz, n, out);
  }
}

void CpuHashGrid::backwardLevels(const GridLayout& g, const float* xyz, int64_t n, const float* dOut, float* grad,
  int l0, int l1)
{
  switch (g.features)
  {
    case 1:
      return backwardT<1>(g, xyz, n, dOut, grad, l0, l1);
    case 2:
      return backwardT<2>(g, xyz, n, dOut, grad, l0, l1);
    case 4:
      return backwardT<4>(g, xyz, n, dOut, grad, l0, l1);
    default:
      return backwardT<8>(g, xyz, n, dOut, grad, l0, l1);
  }
}

} // namespace nv
