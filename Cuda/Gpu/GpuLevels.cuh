// NeuralVolume engine: level-major passes over the hash grid (inference and training). A grid of blocks with
// blockIdx.y = level runs level after level, so the GPU works on one level's slice of the table (or of its
// gradient) at a time and it stays in L2; the fused per-tile kernels touch all levels at once and, on random
// points with a 2^19 table, miss L2 half the time (ncu: 49% L2 hits, 60% of DRAM bandwidth).
#pragma once

#include "GpuNetwork.cuh"

namespace nv
{
namespace gpu
{

struct FwdArgs
{
  GridLayout grid;
  MlpShape shape;
  const __half* table16;
  const __half* w16;
  const float* wout;
  const float* xyz; ///< n x 3, or null: grid points (nx, ny, nz, z0, first), or random training points
  int random;       ///< xyz null and random: randomPoint(seed, step, i)
  uint64_t seed, step;
  int64_t nx, ny, nz, z0, first, n;
  float* out;
  int64_t tiles; ///< 16-sample tiles
  const __half* enc; ///< two-pass mode: encodings, level-major (level l of sample i at (l * n + i) * F)
  int woutOff, encOff, ldE; ///< shared-memory layout (bytes, bytes, halves)
  int wOff[kMaxHidden];     ///< layer offsets in shared memory (halves)
};

/// Index of corner c of a level, same value as cornerIndex() (mask for the power-of-two hashed levels; a dense
/// index is below 2 * entries).
__device__ __forceinline__ uint32_t fastCornerIndex(const LevelInfo& lv, int c, const uint32_t corner[3])
{
  const uint32_t c0 = corner[0] + (c & 1), c1 = corner[1] + ((c >> 1) & 1), c2 = corner[2] + ((c >> 2) & 1);
  uint32_t idx;
  if (lv.hashed)
  {
    idx = (c0 * 1u) ^ (c1 * 2654435761u) ^ (c2 * 805459861u);
    idx &= lv.entries - 1u;
  }
  else
  {
    idx = c0 + c1 * lv.res + c2 * lv.res * lv.res;
    idx = idx >= lv.entries ? idx - lv.entries : idx;
  }
  return lv.offset + idx;
}

/// Coordinates of sample gi (0 beyond n).
__device__ __forceinline__ void fwdPoint(const FwdArgs& a, int64_t gi, float x[3])
{
  x[0] = x[1] = x[2] = 0.0f;
  if (gi >= a.n)
    return;
  if (a.random)
  {
    randomPoint(a.seed, a.step, static_cast<uint64_t>(gi), x);
  }
  else if (a.xyz)
  {
    x[0] = a.xyz[3 * gi];
    x[1] = a.xyz[3 * gi + 1];
    x[2] = a.xyz[3 * gi + 2];
  }
  else
  {
    const int64_t li = a.first + gi;
    const int64_t row = li / a.nx;
    x[0] = gridCoord(li - row * a.nx, a.nx);
    x[1] = gridCoord(row % a.ny, a.ny);
    x[2] = gridCoord(a.z0 + row / a.ny, a.nz);
  }
}

/// Two-pass mode, pass 1: one (sample, level) per thread, level = blockIdx.y. Blocks run in order of level, so
/// the GPU works on one level's table (<= 2^log2T entries) at a time: it stays in L2 instead of the whole table
/// competing for it (the fused kernel on random points is L2/DRAM bound: 49% L2 hit rate, ncu).
template <int F>
__global__ void __launch_bounds__(256) encodeLevelsKernel(const __grid_constant__ FwdArgs a, __half* __restrict__ enc)
{
  using V = typename HalfVec<F>::T;
  const int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x;
  if (i >= a.n)
    return;
  const int l = blockIdx.y;
  float x[3];
  fwdPoint(a, i, x);
  const LevelInfo& lv = a.grid.level[l];
  uint32_t corner[3];
  float frac[3];
  gridPosition(lv, x, corner, frac);
  V v[8];
#pragma unroll
  for (int c = 0; c < 8; ++c)
    v[c] = __ldg(reinterpret_cast<const V*>(a.table16) + fastCornerIndex(lv, c, corner));
  float acc[F];
#pragma unroll
  for (int f = 0; f < F; ++f)
    acc[f] = 0.0f;
#pragma unroll
  for (int c = 0; c < 8; ++c)
  {
    const float w = cornerWeight(c, frac);
    const __half* h = reinterpret_cast<const __half*>(&v[c]);
#pragma unroll
    for (int f = 0; f < F; ++f)
      acc[f] += w * __half2float(h[f]);
  }
  __align__(16) __half o[F];
#pragma unroll
  for (int f = 0; f < F; ++f)
    o[f] = __float2half_rn(acc[f]);
  reinterpret_cast<V*>(enc)[l * a.n + i] = *reinterpret_cast<const V*>(o);
}

/// Two-pass training, pass 3: table gradient from dEnc (fp32, level-major like the encodings), level = blockIdx.y
/// (the level's gradient slice stays in L2 while its atomics land). Same arithmetic as scatterTile.
template <int F>
__global__ void __launch_bounds__(256) scatterLevelsKernel(const __grid_constant__ FwdArgs a,
  const float* __restrict__ dEnc, float* __restrict__ grad)
{
  const int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x;
  if (i >= a.n)
    return;
  const int l = blockIdx.y;
  float d[F];
  bool any = false;
#pragma unroll
  for (int f = 0; f < F; ++f)
  {
    d[f] = dEnc[(l * a.n + i) * F + f];
    any |= d[f] != 0.0f;
  }
  if (!any)
    return;
  float x[3];
  fwdPoint(a, i, x);
  const LevelInfo& lv = a.grid.level[l];
  uint32_t corner[3];
  float frac[3];
  gridPosition(lv, x, corner, frac);
#pragma unroll
  for (int c = 0; c < 8; ++c)
  {
    const float w = cornerWeight(c, frac);
    float v[F];
#pragma unroll
    for (int f = 0; f < F; ++f)
      v[f] = w * d[f];
    atomicAddVec<F>(grad + static_cast<size_t>(fastCornerIndex(lv, c, corner)) * F, v);
  }
}

} // namespace gpu
} // namespace nv
