// NeuralVolume engine: level-major passes over the hash grid (inference and training). A grid of blocks with
// blockIdx.y = level runs level after level, so the GPU works on one level's slice of the table (or of its
// gradient) at a time and it stays in L2; the fused per-tile kernels touch all levels at once and, on random
// points with a 2^19 table, miss L2 half the time (ncu: 49% L2 hits, 60% of DRAM bandwidth).
#pragma once

#include "GpuNetwork.cuh"

#include <type_traits>

namespace nv
{
namespace gpu
{

struct FwdArgs
{
  GridLayout grid;
  MlpShape shape;
  const __half* table16;
  const float* table32; ///< training: encode from the fp32 parameters (encodeLevelsKernel<F, float>)
  const __half* w16;
  const float* wout;
  const float* xyz; ///< sampleCount x 3, or null: grid points (nx, ny, nz, z0, first), or random training points
  int random;       ///< xyz null and random: randomPoint(seed, step, i)
  uint64_t seed, step;
  int64_t nx, ny, nz, z0, first, sampleCount;
  float* out;
  const float4* binned; ///< inference on binned points (GpuBinning.cuh): x, y, z and the output index as float bits
  const __half* enc; ///< two-pass mode: encodings, level-major (level l of sample i at (l * n + i) * F)
  int woutOff, encOff, ldE; ///< shared-memory layout (bytes, bytes, halves)
  int wOff[kMaxHidden];     ///< layer offsets in shared memory (halves)
  /// Inference on a point array whose length is known on the device only (Sample Streaming's device-driven loop):
  /// the samples are [0, *liveCount - liveBase) clamped to [0, sampleCount); sampleCount is then the capacity (and
  /// the level-major stride of the encodings). Null: sampleCount samples.
  const uint32_t* liveCount;
  int64_t liveBase;
};

/// Samples of this launch: sampleCount, or those of the device-side count (FwdArgs::liveCount).
__device__ __forceinline__ int64_t liveSamples(const FwdArgs& a)
{
  if (!a.liveCount)
    return a.sampleCount;
  const int64_t n = static_cast<int64_t>(*a.liveCount) - a.liveBase;
  return n < 0 ? 0 : (n > a.sampleCount ? a.sampleCount : n);
}

/// Index of corner c of a level, same value as cornerIndex() (mask for the power-of-two hashed levels; a dense
/// index is below 2 * entries).
__device__ __forceinline__ uint32_t fastCornerIndex(const LevelInfo& lv, int c, const uint32_t corner[3])
{
  const uint32_t c0 = corner[0] + (c & 1), c1 = corner[1] + ((c >> 1) & 1), c2 = corner[2] + ((c >> 2) & 1);
  uint32_t idx;
  if (lv.hashed)
  {
    idx = spatialHash(c0, c1, c2);
    idx &= lv.entries - 1u;
  }
  else
  {
    idx = c0 + c1 * lv.res + c2 * lv.res * lv.res;
    idx = idx >= lv.entries ? idx - lv.entries : idx;
  }
  return lv.offset + idx;
}

/// grad (fp16) += w_c * d at the 8 corners of a level. For F = 2 / 4 the x-neighbour corners c, c + 1 that land in
/// one aligned pair of entries (2k, 2k + 1) -- a hashed level's corner with even x, half of a dense level's -- go
/// in one vector reduction of both entries: a quarter fewer L2 atomics. G = Fixed: deterministic mode, one 64-bit
/// integer atomic per feature (GpuFixedPoint.cuh).
template <int F, typename G>
__device__ __forceinline__ void scatterCorners(G* __restrict__ grad, const LevelInfo& lv, const uint32_t corner[3],
  const float frac[3], const float* d)
{
  constexpr bool kHalf = std::is_same<G, __half>::value;
#pragma unroll
  for (int c = 0; c < 8; c += 2)
  {
    const uint32_t i0 = fastCornerIndex(lv, c, corner), i1 = fastCornerIndex(lv, c + 1, corner);
    const float w0 = cornerWeight(c, frac), w1 = cornerWeight(c + 1, frac);
    if (kHalf && (F == 2 || F == 4) && (i0 ^ i1) == 1u)
    {
      const bool order = i0 < i1;
      const float wl = order ? w0 : w1, wh = order ? w1 : w0;
      G* p = grad + static_cast<size_t>(i0 & ~1u) * F;
      if constexpr (!kHalf)
        ;
      else if constexpr (F == 2)
        reduceHalfPairs2(p, halves2(wl * d[0], wl * d[1]), halves2(wh * d[0], wh * d[1]));
      else if constexpr (F == 4)
        reduceHalfPairs4(p, halves2(wl * d[0], wl * d[1]), halves2(wl * d[2], wl * d[3]), halves2(wh * d[0], wh * d[1]),
          halves2(wh * d[2], wh * d[3]));
    }
    else
    {
      float v[F];
#pragma unroll
      for (int f = 0; f < F; ++f)
        v[f] = w0 * d[f];
      atomicAddVec<F>(grad + static_cast<size_t>(i0) * F, v);
#pragma unroll
      for (int f = 0; f < F; ++f)
        v[f] = w1 * d[f];
      atomicAddVec<F>(grad + static_cast<size_t>(i1) * F, v);
    }
  }
}

/// Coordinates of sample gi (0 beyond the samples).
__device__ __forceinline__ void fwdPoint(const FwdArgs& a, int64_t gi, float x[3])
{
  x[0] = x[1] = x[2] = 0.0f;
  if (gi >= liveSamples(a))
    return;
  if (a.binned)
  {
    const float4 q = a.binned[gi];
    x[0] = q.x;
    x[1] = q.y;
    x[2] = q.z;
  }
  else if (a.random)
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

/// Two-pass mode, pass 1: one sample and Lpt consecutive levels per thread, levels blockIdx.y * Lpt + k. Blocks
/// run in order of blockIdx.y, so the GPU works on Lpt levels' tables (<= 2^log2T entries each) at a time: they stay
/// in L2 instead of the whole table competing for it (the fused kernel on random points is L2/DRAM bound: 49% L2
/// hits, ncu); Lpt > 1 reads the coordinates once for several levels.
template <int F, typename T, int Lpt>
__device__ __forceinline__ void encodeSampleLevels(const FwdArgs& a, int64_t i, __half* __restrict__ enc)
{
  using E = Entry<T, F>;
  using V = typename HalfVec<F>::T;
  float x[3];
  fwdPoint(a, i, x);
  const T* table = a.table32 ? reinterpret_cast<const T*>(a.table32) : reinterpret_cast<const T*>(a.table16);
#pragma unroll
  for (int k = 0; k < Lpt; ++k)
  {
    const int l = blockIdx.y * Lpt + k;
    if (l >= a.grid.levels)
      break;
    const LevelInfo& lv = a.grid.level[l];
    uint32_t corner[3];
    float frac[3];
    gridPosition(lv, x, corner, frac);
    typename E::V v[8];
    if constexpr (std::is_same<T, __half>::value && F == 4)
    {
      // x-neighbour corners in one aligned pair of entries (2k, 2k + 1; a hashed level's corner with even x) come
      // in one 16-byte load (measured +2% on random points: the second 8-byte load mostly hits L1 anyway).
#pragma unroll
      for (int c = 0; c < 8; c += 2)
      {
        const uint32_t i0 = fastCornerIndex(lv, c, corner), i1 = fastCornerIndex(lv, c + 1, corner);
        if ((i0 ^ i1) == 1u)
        {
          const uint4 q = __ldg(reinterpret_cast<const uint4*>(table) + (i0 >> 1));
          const uint2 lo = make_uint2(q.x, q.y), hi = make_uint2(q.z, q.w);
          v[c] = (i0 & 1u) ? hi : lo;
          v[c + 1] = (i0 & 1u) ? lo : hi;
        }
        else
        {
          v[c] = E::load(table, i0);
          v[c + 1] = E::load(table, i1);
        }
      }
    }
    else
    {
#pragma unroll
      for (int c = 0; c < 8; ++c)
        v[c] = E::load(table, fastCornerIndex(lv, c, corner));
    }
    float acc[F];
    interpolate<F, E>(v, frac, acc);
    __align__(16) __half o[F];
#pragma unroll
    for (int f = 0; f < F; ++f)
      o[f] = __float2half_rn(acc[f]);
    // Streaming store (evict-first): the encodings are read once by the MLP pass; keep L2 for the level's table.
    __stcs(reinterpret_cast<V*>(enc) + l * a.sampleCount + i, *reinterpret_cast<const V*>(o));
  }
}

/// Two-pass mode, pass 1 (see encodeSampleLevels). A grid that covers the samples runs one sample per thread; a
/// smaller one (a device-side count, FwdArgs::liveCount: sized for the capacity) strides over them.
template <int F, typename T = __half, int Lpt = 1>
__global__ void __launch_bounds__(256) encodeLevelsKernel(const __grid_constant__ FwdArgs a, __half* __restrict__ enc)
{
  const int64_t n = liveSamples(a);
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
    encodeSampleLevels<F, T, Lpt>(a, i, enc);
}

/// Two-pass training, pass 3: the table gradient (fp16, unscaled) from dEnc (fp32, level-major like the
/// encodings); level = blockIdx.y, so one level's gradient slice is in L2 while its atomics land. G: __half, or
/// Fixed in deterministic mode.
template <int F, typename G>
__global__ void __launch_bounds__(256) scatterLevelsKernel(const __grid_constant__ FwdArgs a,
  const float* __restrict__ dEnc, G* __restrict__ grad)
{
  const int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x;
  if (i >= a.sampleCount)
    return;
  const int l = blockIdx.y;
  float d[F];
  bool any = false;
#pragma unroll
  for (int f = 0; f < F; ++f)
  {
    d[f] = __ldcs(dEnc + (l * a.sampleCount + i) * F + f);
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
  scatterCorners<F>(grad, lv, corner, frac, d);
}

} // namespace gpu
} // namespace nv
