#include "CpuMacrocells.h"

#include "Core/HashGridMath.h"
#include "CpuInference.h"
#include "CpuGridSampler.h"
#include "ThreadPool.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace nv
{

bool CpuMacrocells::updateRanges(ThreadPool& pool, const MacrocellLayout& layout, const float* lattice,
  const int64_t L[3], uint64_t latticeId, float margin, const CpuInference* net, int probesPerCell)
{
  const bool sameLayout = std::memcmp(&layout, &Layout, sizeof(Layout)) == 0;
  const int probes = net ? std::max(0, probesPerCell) : 0;
  if (sameLayout && latticeId == LatticeId && margin == Margin && probes == Probes && !Lo.empty())
    return false;
  Layout = layout;
  LatticeId = latticeId;
  Margin = margin;
  Probes = probes;
  const int64_t cx = layout.dims[0], cy = layout.dims[1], cz = layout.dims[2];
  const int64_t cells = cx * cy * cz;
  Lo.assign(static_cast<size_t>(cells), 0.0f);
  Hi.assign(static_cast<size_t>(cells), 0.0f);
  pool.parallelChunks(cells, 16, [&](int64_t b, int64_t e, int) {
    for (int64_t c = b; c < e; ++c)
    {
      const int x = static_cast<int>(c % cx), y = static_cast<int>((c / cx) % cy), z = static_cast<int>(c / (cx * cy));
      cellRange(Layout, lattice, L, x, y, z, margin, Lo[static_cast<size_t>(c)], Hi[static_cast<size_t>(c)]);
    }
  });
  Widening = margin;
  if (probes > 0)
  {
    // Probe points: uniform inside each cell (cell c spans [c, c + 1) / scale per axis, clipped to [0, 1]).
    const int64_t n = cells * probes;
    std::vector<float> xyz(3 * static_cast<size_t>(n)), v(static_cast<size_t>(n));
    pool.parallelFor(cells, [&](int64_t b, int64_t e, int) {
      for (int64_t c = b; c < e; ++c)
      {
        const int64_t ci[3] = { c % cx, (c / cx) % cy, c / (cx * cy) };
        for (int k = 0; k < probes; ++k)
        {
          float* p = &xyz[3 * static_cast<size_t>(c * probes + k)];
          randomPoint(0x6d617267696eull, static_cast<uint64_t>(c), static_cast<uint64_t>(k), p);
          for (int a = 0; a < 3; ++a)
          {
            const float lo = static_cast<float>(ci[a]) / layout.scale[a];
            const float hi = std::min(1.0f, static_cast<float>(ci[a] + 1) / layout.scale[a]);
            p[a] = std::min(1.0f, lo + p[a] * (hi - lo));
          }
        }
      }
    });
    net->inferPoints(pool, xyz.data(), n, v.data());
    const CpuGridSampler lookup(lattice, L, false);
    std::vector<float> widest(static_cast<size_t>(pool.size()), 0.0f);
    pool.parallelFor(cells, [&](int64_t b, int64_t e, int w) {
      for (int64_t c = b; c < e; ++c)
      {
        float lo = Lo[static_cast<size_t>(c)], hi = Hi[static_cast<size_t>(c)], dev = 0.0f;
        for (int k = 0; k < probes; ++k)
        {
          const size_t i = static_cast<size_t>(c * probes + k);
          const float y = v[i];
          lo = std::min(lo, y);
          hi = std::max(hi, y);
          dev = std::max(dev, std::fabs(y - lookup(&xyz[3 * i])));
        }
        const float m = kProbeSafety * dev + kNetworkFloor;
        lo -= m;
        hi += m;
        widest[static_cast<size_t>(w)] = std::max(widest[static_cast<size_t>(w)],
          std::max(Lo[static_cast<size_t>(c)] - lo, hi - Hi[static_cast<size_t>(c)]));
        Lo[static_cast<size_t>(c)] = lo;
        Hi[static_cast<size_t>(c)] = hi;
      }
    });
    Widening = *std::max_element(widest.begin(), widest.end());
  }
  ++RangesVersion;
  return true;
}

void CpuMacrocells::setEmptyCells(const uint32_t* occupancy, float background)
{
  for (size_t c = 0; c < Lo.size(); ++c)
    if (!cellBit(occupancy, static_cast<int64_t>(c)))
      Lo[c] = Hi[c] = background;
}

bool CpuMacrocells::updateMajorants(ThreadPool& pool, const float* tf, int size, float scale, float shift,
  uint64_t tableKey)
{
  const uint64_t h = tableKey;
  if (MajorantRanges == RangesVersion && h == TfHash && Majorant.size() == Lo.size())
    return false;
  MajorantRanges = RangesVersion;
  TfHash = h;
  ++MajorantUpdates;
  const int64_t cells = static_cast<int64_t>(Lo.size());
  Majorant.assign(Lo.size(), 0.0f);
  pool.parallelChunks(cells, 256, [&](int64_t b, int64_t e, int) {
    for (int64_t c = b; c < e; ++c)
      Majorant[static_cast<size_t>(c)] =
        rangeMajorant(tf, size, scale, shift, Lo[static_cast<size_t>(c)], Hi[static_cast<size_t>(c)]);
  });
  MaxMajorant = 0.0f;
  EmptyCells = 0;
  for (float m : Majorant)
  {
    MaxMajorant = std::max(MaxMajorant, m);
    EmptyCells += m > 0.0f ? 0 : 1;
  }
  return true;
}

} // namespace nv
