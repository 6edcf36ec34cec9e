// NeuralVolume engine: device code shared by the GPU kernels -- the padded MLP layout, shared-memory plans, table
// entry loads and trilinear interpolation (used by the forward pass, GpuWarpForward.cuh), table-gradient atomics, and
// the WMMA backward helpers of the general training kernel (GpuTrainWmma.cuh).
#pragma once

#include "Core/HashGridMath.h"
#include "Core/Model.h"
#include "GpuCommon.cuh"
#include "GpuAtomics.cuh"
#include "GpuFixedPoint.cuh"

#include <mma.h>

#include <cstdint>

namespace nv
{
namespace gpu
{

constexpr int kMaxHidden = 8;

/// Padded MLP layout used on the GPU (fp16 weights and fp32 gradients): layer 0 is width x paddedInputs (inputs
/// padded to a multiple of 16 with zero weights), hidden layers width x width, then the output row (width).
struct MlpShape
{
  int width;        ///< neurons per hidden layer
  int hiddenLayers; ///< hidden layers (weight matrices before the output row)
  int inputs;       ///< encoding outputs (levels * features)
  int paddedInputs; ///< inputs rounded up to 16
  int off[kMaxHidden + 1]; ///< padded offset of layer l; off[hiddenLayers] = output row
  int total;               ///< padded size, multiple of 64
  __host__ __device__ int inDim(int l) const { return l == 0 ? paddedInputs : width; }
};

inline MlpShape makeMlpShape(const ModelConfig& c)
{
  MlpShape s{};
  s.width = c.network.width;
  s.hiddenLayers = c.network.hiddenLayers;
  s.inputs = c.encoding.levels * c.encoding.featuresPerLevel;
  s.paddedInputs = (s.inputs + 15) / 16 * 16;
  int o = 0;
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    s.off[l] = o;
    o += s.width * (l == 0 ? s.paddedInputs : s.width);
  }
  s.off[s.hiddenLayers] = o;
  o += s.width;
  s.total = (o + 63) / 64 * 64;
  return s;
}

/// Where unpadded MLP parameter j (Model layout: layer by layer, row-major, then the output row) lives in the
/// padded layout: padded index, and for the output row (layer == H) its column.
struct MlpSlot
{
  int layer;
  int padded;
  int column; ///< output row only
};

__host__ __device__ inline MlpSlot mlpSlot(const MlpShape& s, int64_t j)
{
  int64_t r = j;
  int l = 0;
  for (; l < s.hiddenLayers; ++l)
  {
    const int64_t sz = int64_t(s.width) * (l == 0 ? s.inputs : s.width);
    if (r < sz)
      break;
    r -= sz;
  }
  if (l == s.hiddenLayers)
    return { l, s.off[s.hiddenLayers] + static_cast<int>(r), static_cast<int>(r) };
  const int K = l == 0 ? s.inputs : s.width;
  return { l, s.off[l] + static_cast<int>(r / K) * s.inDim(l) + static_cast<int>(r % K), 0 };
}

inline size_t roundUp128(size_t x)
{
  return (x + 127) / 128 * 128;
}

/// Shared-memory plan of a block (bytes offsets). Training keeps every hidden activation for the backward pass.
struct SmemPlan
{
  int tileSamples, warps; ///< samples per block iteration (16 per warp), warps per block
  int ldE, ldA, ldDE; ///< leading dimensions: enc (halves), activations (halves), dEnc (floats)
  /// Byte offsets of the regions; outputGrads: the tile's outputs, turned into their loss gradients by the loss.
  int xyz, targets, outputGrads, enc, acts, dz0, dz1, stage, weights, wout;
  int wOff[kMaxHidden]; ///< smem weight layer offsets (halves, relative to w)
  int total;
  bool wInSmem;
};

inline SmemPlan makeSmemPlan(const MlpShape& s, int warps, bool training, bool wInSmem)
{
  SmemPlan p{};
  p.warps = warps;
  p.tileSamples = 16 * warps;
  p.ldE = s.paddedInputs + 8;
  p.ldA = s.width + 8;
  p.ldDE = s.paddedInputs + 4;
  p.wInSmem = wInSmem;
  size_t o = 0;
  auto take = [&](size_t bytes) {
    const size_t at = o;
    o += roundUp128(bytes);
    return static_cast<int>(at);
  };
  const size_t T = p.tileSamples;
  p.xyz = take(T * 3 * 4);
  p.targets = take(T * 4);
  p.outputGrads = take(T * 4);
  p.enc = take(T * p.ldE * 2);
  if (training)
  {
    const size_t actsBytes = static_cast<size_t>(s.hiddenLayers) * T * p.ldA * 2;
    const size_t dEncBytes = T * p.ldDE * 4; // aliases the activations (dead when dEnc is written)
    p.acts = take(actsBytes > dEncBytes ? actsBytes : dEncBytes);
    p.dz0 = take(T * p.ldA * 2);
    p.dz1 = take(T * p.ldA * 2);
  }
  else
  {
    p.acts = take(T * p.ldA * 2);
    p.dz0 = p.dz1 = 0;
  }
  p.stage = take(static_cast<size_t>(warps) * 256 * 4);
  p.wout = take(s.width * 4);
  size_t wh = 0;
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    p.wOff[l] = static_cast<int>(wh);
    wh += static_cast<size_t>(s.width) * (s.inDim(l) + 8);
  }
  p.weights = wInSmem ? take(wh * 2) : 0;
  p.total = static_cast<int>(o);
  return p;
}

// ---------------------------------------------------------------------------------------------------------
// Device helpers

template <int F>
struct HalfVec;
template <>
struct HalfVec<1>
{
  using T = __half;
};
template <>
struct HalfVec<2>
{
  using T = __half2;
};
template <>
struct HalfVec<4>
{
  using T = uint2;
};
template <>
struct HalfVec<8>
{
  using T = uint4;
};

/// One table entry (F features) as loaded by the encoders: fp16 (inference, the fp16 copy) or fp32 (training on
/// the fp32 master parameters: no fp16 copy to write per step; an entry is still one 32-byte sector or less).
template <typename T, int F>
struct Entry;
template <int F>
struct Entry<__half, F>
{
  using V = typename HalfVec<F>::T;
  static __device__ __forceinline__ V load(const __half* t, uint32_t i) { return __ldg(reinterpret_cast<const V*>(t) + i); }
  static __device__ __forceinline__ float get(const V& v, int f) { return __half2float(reinterpret_cast<const __half*>(&v)[f]); }
};
template <int F>
struct FloatVec;
template <>
struct FloatVec<1>
{
  using T = float;
};
template <>
struct FloatVec<2>
{
  using T = float2;
};
template <>
struct FloatVec<4>
{
  using T = float4;
};
template <int F>
struct Entry<float, F>
{
  struct alignas(F >= 4 ? 16 : 4 * F) V
  {
    typename FloatVec<(F > 4 ? 4 : F)>::T part[F > 4 ? F / 4 : 1];
  };
  static __device__ __forceinline__ V load(const float* t, uint32_t i)
  {
    using P = typename FloatVec<(F > 4 ? 4 : F)>::T;
    const P* q = reinterpret_cast<const P*>(t + size_t(i) * F);
    V v;
#pragma unroll
    for (int k = 0; k < (F > 4 ? F / 4 : 1); ++k)
      v.part[k] = __ldg(q + k);
    return v;
  }
  static __device__ __forceinline__ float get(const V& v, int f) { return reinterpret_cast<const float*>(&v)[f]; }
};

/// acc = trilinear interpolation of the 8 corner entries v (corner c: bit d = offset along axis d).
template <int F, typename E>
__device__ __forceinline__ void interpolate(const typename E::V (&v)[8], const float frac[3], float (&acc)[F])
{
#pragma unroll
  for (int f = 0; f < F; ++f)
    acc[f] = 0.0f;
#pragma unroll
  for (int c = 0; c < 8; ++c)
  {
    const float w = cornerWeight(c, frac);
#pragma unroll
    for (int f = 0; f < F; ++f)
      acc[f] += w * E::get(v[c], f);
  }
}

/// acc[k] = interpolated features of item k (k = 0, 1) from its 8 corner indices and fractions; all 16 gathers are
/// issued before the first is used (the encoders' two items per iteration).
template <int F, typename E, typename T>
__device__ __forceinline__ void gatherTwo(const T* __restrict__ table, const uint32_t (&idx)[2][8],
  const float (&frac)[2][3], float (&acc)[2][F])
{
  typename E::V v[2][8];
#pragma unroll
  for (int k = 0; k < 2; ++k)
#pragma unroll
    for (int c = 0; c < 8; ++c)
      v[k][c] = E::load(table, idx[k][c]);
#pragma unroll
  for (int k = 0; k < 2; ++k)
    interpolate<F, E>(v[k], frac[k], acc[k]);
}

template <int F>
__device__ __forceinline__ void atomicAddVec(float* p, const float* v)
{
  if constexpr (F == 1)
  {
    atomicAdd(p, v[0]);
  }
  else if constexpr (F == 2)
  {
    atomicAddPair(p, v[0], v[1]);
  }
  else
  {
#pragma unroll
    for (int q = 0; q < F / 4; ++q)
      atomicAddQuad(p + 4 * q, v[4 * q], v[4 * q + 1], v[4 * q + 2], v[4 * q + 3]);
  }
}

__device__ __forceinline__ uint32_t halves2(float x, float y)
{
  const __half2 h = __floats2half2_rn(x, y);
  return *reinterpret_cast<const uint32_t*>(&h);
}

/// p[0..F) += v for an fp16 gradient table: packed f16x2 reductions (on sm_90+ one vector instruction per entry for
/// F <= 8: half the L2 atomic work of fp32 float4 reductions).
template <int F>
__device__ __forceinline__ void atomicAddVec(__half* p, const float* v)
{
  if constexpr (F == 1)
  {
    atomicAdd(p, __float2half_rn(v[0]));
  }
  else if constexpr (F == 2)
  {
    reduceHalfPair(p, halves2(v[0], v[1]));
  }
  else if constexpr (F == 4)
  {
    reduceHalfPairs2(p, halves2(v[0], v[1]), halves2(v[2], v[3]));
  }
  else
  {
    reduceHalfPairs4(p, halves2(v[0], v[1]), halves2(v[2], v[3]), halves2(v[4], v[5]), halves2(v[6], v[7]));
  }
}

/// grad += d(loss)/d(table) for the tile, from dEnc (T x ldDE floats). Samples t >= valid are skipped. G: __half
/// (fp16 atomics) or Fixed (deterministic mode, GpuFixedPoint.cuh).
template <int F, typename G>
__device__ __forceinline__ void scatterTile(const GridLayout& g, G* __restrict__ grad, const float* sx,
  const float* dEnc, int ldDE, int T, int valid)
{
  const int items = T * g.levels;
  for (int it = threadIdx.x; it < items; it += blockDim.x)
  {
    const int t = it % T, l = it / T;
    if (t >= valid)
      continue;
    float d[F];
    bool any = false;
#pragma unroll
    for (int f = 0; f < F; ++f)
    {
      d[f] = dEnc[t * ldDE + l * F + f];
      any |= d[f] != 0.0f;
    }
    if (!any)
      continue;
    const LevelInfo& lv = g.level[l];
    const float x[3] = { sx[3 * t], sx[3 * t + 1], sx[3 * t + 2] };
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
      atomicAddVec<F>(grad + static_cast<size_t>(cornerIndex(lv, c, corner)) * F, v);
    }
  }
}

namespace wm = nvcuda::wmma;
using FragA = wm::fragment<wm::matrix_a, 16, 16, 16, __half, wm::row_major>;
using FragAc = wm::fragment<wm::matrix_a, 16, 16, 16, __half, wm::col_major>;
using FragBc = wm::fragment<wm::matrix_b, 16, 16, 16, __half, wm::col_major>;
using FragBr = wm::fragment<wm::matrix_b, 16, 16, 16, __half, wm::row_major>;
using FragC = wm::fragment<wm::accumulator, 16, 16, 16, float>;

/// dA = dZ[rows] . Wl (Wl row-major [W][K], ld ldw). If dEnc: stored there in fp32; else
/// dZout = (mask > 0) * dA in fp16 (mask, dZout: ld ldA).
template <int W>
__device__ __forceinline__ void backwardInput(const __half* dZ, int ldZ, const __half* Wl, int ldw, int K, int row0,
  int lane, float* stage, const __half* mask, __half* dZout, int ldA, float* dEnc, int ldDE)
{
  const int r = lane >> 1, c0 = (lane & 1) * 8;
  for (int j = 0; j < K / 16; ++j)
  {
    FragC c;
    wm::fill_fragment(c, 0.0f);
#pragma unroll
    for (int k = 0; k < W / 16; ++k)
    {
      FragA a;
      wm::load_matrix_sync(a, dZ + row0 * ldZ + k * 16, ldZ);
      FragBr b;
      wm::load_matrix_sync(b, Wl + k * 16 * ldw + j * 16, ldw);
      wm::mma_sync(c, a, b, c);
    }
    if (dEnc)
    {
      wm::store_matrix_sync(dEnc + row0 * ldDE + j * 16, c, ldDE, wm::mem_row_major);
      continue;
    }
    wm::store_matrix_sync(stage, c, 16, wm::mem_row_major);
    __syncwarp();
    const __half* m = mask + (row0 + r) * ldA + j * 16 + c0;
    __align__(16) __half h[8];
#pragma unroll
    for (int q = 0; q < 8; ++q)
      h[q] = __hgt(m[q], __float2half(0.0f)) ? __float2half_rn(stage[r * 16 + c0 + q]) : __float2half(0.0f);
    *reinterpret_cast<uint4*>(dZout + (row0 + r) * ldA + j * 16 + c0) = *reinterpret_cast<const uint4*>(h);
    __syncwarp();
  }
}

/// dWl (+)= dZ^T . X over the T samples of the tile; dst: fp32 [W][K] row-major in global memory.
template <int W>
__device__ __forceinline__ void weightGrad(const __half* dZ, int ldZ, const __half* X, int ldX, int K, int T,
  float* dst, bool first, int warp, int warps)
{
  const int nt = K / 16;
  for (int tile = warp; tile < (W / 16) * nt; tile += warps)
  {
    const int mi = tile / nt, ni = tile % nt;
    float* d = dst + mi * 16 * K + ni * 16;
    FragC c;
    if (first)
      wm::fill_fragment(c, 0.0f);
    else
      wm::load_matrix_sync(c, d, K, wm::mem_row_major);
    for (int kc = 0; kc < T; kc += 16)
    {
      FragAc a;
      wm::load_matrix_sync(a, dZ + kc * ldZ + mi * 16, ldZ);
      FragBr b;
      wm::load_matrix_sync(b, X + kc * ldX + ni * 16, ldX);
      wm::mma_sync(c, a, b, c);
    }
    wm::store_matrix_sync(d, c, K, wm::mem_row_major);
  }
}

/// Copy the padded fp16 weights (and fp32 output row) into shared memory when the plan says so; returns the
/// layer pointers / leading dimensions to use.
__device__ __forceinline__ void stageWeights(const MlpShape& s, const SmemPlan& p, unsigned char* smem,
  const __half* __restrict__ w16, const float* __restrict__ wout, const __half** wl, int* ldw)
{
  float* sw = reinterpret_cast<float*>(smem + p.wout);
  for (int i = threadIdx.x; i < s.width; i += blockDim.x)
    sw[i] = wout[i];
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    const int K = s.inDim(l);
    if (p.wInSmem)
    {
      __half* dst = reinterpret_cast<__half*>(smem + p.weights) + p.wOff[l];
      const __half* src = w16 + s.off[l];
      for (int i = threadIdx.x; i < s.width * K; i += blockDim.x)
        dst[(i / K) * (K + 8) + i % K] = src[i];
      wl[l] = dst;
      ldw[l] = K + 8;
    }
    else
    {
      wl[l] = w16 + s.off[l];
      ldw[l] = K;
    }
  }
}

/// Coordinate of sample i of n along an axis: i/(n-1), 0.5 when n == 1 (as gridCoordinate on the CPU).
__device__ __forceinline__ float gridCoord(int64_t i, int64_t n)
{
  return n <= 1 ? 0.5f : static_cast<float>(static_cast<double>(i) / static_cast<double>(n - 1));
}

} // namespace gpu
} // namespace nv
