#include "CpuHashGrid.h"

namespace nv
{
namespace
{

template <int F>
void encodeT(const GridLayout& g, const float* table, const float* xyz, int64_t n, float* out)
{
  const int L = g.levels;
  const int stride = L * F;
  for (int64_t s = 0; s < n; ++s)
  {
    const float* x = xyz + 3 * s;
    float* o = out + s * stride;
    for (int l = 0; l < L; ++l)
    {
      const LevelInfo& lv = g.level[l];
      uint32_t corner[3];
      float frac[3];
      gridPosition(lv, x, corner, frac);
      float acc[F] = {};
      for (int c = 0; c < 8; ++c)
      {
        const float w = cornerWeight(c, frac);
        const float* e = table + static_cast<size_t>(cornerIndex(lv, c, corner)) * F;
        for (int f = 0; f < F; ++f)
        {
          acc[f] += w * e[f];
        }
      }
      for (int f = 0; f < F; ++f)
      {
        o[l * F + f] = acc[f];
      }
    }
  }
}

template <int F>
void backwardT(const GridLayout& g, const float* xyz, int64_t n, const float* dOut, float* grad, int l0, int l1)
{
  const int stride = g.levels * F;
  for (int l = l0; l < l1; ++l)
  {
    const LevelInfo& lv = g.level[l];
    for (int64_t s = 0; s < n; ++s)
    {
      const float* d = dOut + s * stride + l * F;
      bool any = false;
      for (int f = 0; f < F; ++f)
      {
        any |= d[f] != 0.0f;
      }
      if (!any)
      {
        continue;
      }
      uint32_t corner[3];
      float frac[3];
      gridPosition(lv, xyz + 3 * s, corner, frac);
      for (int c = 0; c < 8; ++c)
      {
        const float w = cornerWeight(c, frac);
        float* e = grad + static_cast<size_t>(cornerIndex(lv, c, corner)) * F;
        for (int f = 0; f < F; ++f)
        {
          e[f] += w * d[f];
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
