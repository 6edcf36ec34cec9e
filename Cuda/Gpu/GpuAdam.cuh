// NeuralVolume engine: the Adam kernels of the GPU trainer (hash table: one memory-bound pass that also writes the
// fp16 copy and zeroes the gradient; MLP: unpadded parameters from the padded gradient), and the deterministic
// mode's conversion of the fixed-point gradient sums that Adam then reads.
#pragma once

#include "Core/Config.h"
#include "GpuStepCounters.cuh"

#include <cmath>

namespace nv
{
namespace gpu
{
namespace
{

struct AdamArgs
{
  float b1, b2, a1, a2, eps, stepSize, invSqrtBc2;
  float stateScale; ///< hash-table moments are kept in units of stateScale x gradient (the batch size)
  uint32_t noise;   ///< per-step seed of the stochastic rounding of the table moments
};

/// The Adam constants of step s (1-based): bias corrections, the schedule's rate times plateauScale
/// (PlateauSchedule), the table moments' scale (the batch) and the seed of their stochastic rounding.
inline AdamArgs makeAdamArgs(const TrainConfig& train, double plateauScale, int64_t s)
{
  const OptimizerConfig& o = train.optimizer;
  const double bc1 = 1.0 - std::pow(o.beta1, static_cast<double>(s));
  const double bc2 = 1.0 - std::pow(o.beta2, static_cast<double>(s));
  const double lr = static_cast<float>(o.learningRateAt(s) * plateauScale);
  AdamArgs a;
  a.b1 = static_cast<float>(o.beta1);
  a.b2 = static_cast<float>(o.beta2);
  a.a1 = 1.0f - a.b1;
  a.a2 = 1.0f - a.b2;
  a.eps = static_cast<float>(o.epsilon);
  a.stepSize = static_cast<float>(lr / bc1);
  a.invSqrtBc2 = static_cast<float>(1.0 / std::sqrt(bc2));
  a.stateScale = static_cast<float>(train.batchSize);
  a.noise = static_cast<uint32_t>(mix64(train.seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(s)));
  return a;
}

__device__ __forceinline__ void adamOne(float& p, float& g, float& m, float& v, float scale, const AdamArgs& a)
{
  const float gi = g * scale;
  g = 0.0f;
  m = a.b1 * m + a.a1 * gi;
  v = a.b2 * v + a.a2 * gi * gi;
  p -= a.stepSize * m / (sqrtf(v) * a.invSqrtBc2 + a.eps);
}

__device__ __forceinline__ uint32_t hash32(uint32_t x)
{
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

/// bf16 bits of x rounded stochastically with 16 random bits r (unbiased: E[result] = x).
__device__ __forceinline__ uint32_t bf16Stochastic(float x, uint32_t r)
{
  return (__float_as_uint(x) + (r & 0xffffu)) >> 16;
}

/// Adam for one hash-table parameter with 16-bit state: mv = (m, sqrt(v)) as two bf16 (m in the low half), in
/// units of stateScale x gradient, rounded stochastically so that the moving averages stay unbiased (an update
/// below half a bf16 step is kept on average instead of lost). The update itself is the fp32 Adam update with eps
/// scaled alike. gmul = stateScale / valid samples / loss-gradient scale (the table gradient is unscaled).
__device__ __forceinline__ void adamHalfState(float& p, float g, uint32_t& mv, float gmul, uint32_t r,
  const AdamArgs& a)
{
  const float mOld = __uint_as_float(mv << 16), sOld = __uint_as_float(mv & 0xffff0000u);
  const float gi = g * gmul;
  const float m = a.b1 * mOld + a.a1 * gi;
  const float s = sqrtf(a.b2 * sOld * sOld + a.a2 * gi * gi);
  p -= a.stepSize * m / (s * a.invSqrtBc2 + a.eps * a.stateScale);
  mv = bf16Stochastic(m, r) | (bf16Stochastic(s, r >> 16) << 16);
}

/// Four table parameters at float4 index i: read p, g (fp16), mv (2 x bf16); write p, mv, fp16 p; zero g. Streaming loads and
/// stores (evict-first): each byte is touched once per step. 20 bytes per parameter (22 with the fp16 copy).
__device__ __forceinline__ void adamTable4(float* __restrict__ p, __half* __restrict__ g, uint32_t* __restrict__ mv,
  __half* __restrict__ p16, int64_t i, float gmul, const AdamArgs& a)
{
  float4 P = __ldcs(reinterpret_cast<const float4*>(p) + i);
  const uint2 G = __ldcs(reinterpret_cast<const uint2*>(g) + i);
  uint4 MV = __ldcs(reinterpret_cast<const uint4*>(mv) + i);
  const __half2 g01 = *reinterpret_cast<const __half2*>(&G.x), g23 = *reinterpret_cast<const __half2*>(&G.y);
  const uint32_t r = static_cast<uint32_t>(i) * 4u;
  adamHalfState(P.x, __low2float(g01), MV.x, gmul, hash32(r ^ a.noise), a);
  adamHalfState(P.y, __high2float(g01), MV.y, gmul, hash32((r + 1u) ^ a.noise), a);
  adamHalfState(P.z, __low2float(g23), MV.z, gmul, hash32((r + 2u) ^ a.noise), a);
  adamHalfState(P.w, __high2float(g23), MV.w, gmul, hash32((r + 3u) ^ a.noise), a);
  __stcs(reinterpret_cast<float4*>(p) + i, P);
  __stcs(reinterpret_cast<uint2*>(g) + i, make_uint2(0u, 0u));
  __stcs(reinterpret_cast<uint4*>(mv) + i, MV);
  if (p16) // only the WMMA training kernel reads the fp16 copy
    __stcs(reinterpret_cast<uint2*>(p16) + i, make_uint2(halves2(P.x, P.y), halves2(P.z, P.w)));
}

__device__ __forceinline__ void adamTable1(float* __restrict__ p, __half* __restrict__ g, uint32_t* __restrict__ mv,
  __half* __restrict__ p16, int64_t i, float gmul, const AdamArgs& a)
{
  adamHalfState(p[i], __half2float(g[i]), mv[i], gmul, hash32(static_cast<uint32_t>(i) ^ a.noise), a);
  g[i] = __float2half(0.0f);
  if (p16)
    p16[i] = __float2half_rn(p[i]);
}

/// The MLP's parameters for the Adam kernel (unpadded Model layout; gradients in the padded accumulator).
struct MlpAdam
{
  float* params;       ///< the MLP's fp32 parameters (unpadded)
  float* firstMoment;  ///< Adam's m
  float* secondMoment; ///< Adam's v
  float* gradPad;
  __half* w16;
  float* wout;
  MlpShape shape;
  int64_t count;
};

/// Adam for MLP parameter j (fp32 state): gradient from the padded accumulator (zeroed), fp16 padded copy out.
__device__ __forceinline__ void adamMlpOne(const MlpAdam& q, int64_t j, float scale, const AdamArgs& a)
{
  const MlpSlot m = mlpSlot(q.shape, j);
  const int pi = m.padded;
  float pj = q.params[j], mj = q.firstMoment[j], vj = q.secondMoment[j], gj = q.gradPad[pi];
  adamOne(pj, gj, mj, vj, scale, a);
  q.params[j] = pj;
  q.firstMoment[j] = mj;
  q.secondMoment[j] = vj;
  q.gradPad[pi] = 0.0f;
  if (m.layer == q.shape.hiddenLayers)
    q.wout[m.column] = pj;
  else
    q.w16[pi] = __float2half_rn(pj);
}

/// One pass over the hash table (adamTable4; n = 0 skips it) and over the MLP (fp32 state).
__global__ void __launch_bounds__(256) adamKernel(float* __restrict__ p, __half* __restrict__ g,
  uint32_t* __restrict__ mv, __half* __restrict__ p16, int64_t n, const __grid_constant__ MlpAdam mlp, AdamArgs a,
  const Counters* __restrict__ counters)
{
  const int cnt = counters->nValid;
  if (cnt == 0)
    return;
  const float unscale = 1.0f / counters->gradScale;
  const float gmul = a.stateScale * unscale / static_cast<float>(cnt);
  const int64_t n4 = n / 4;
  const int64_t first = blockIdx.x * int64_t(blockDim.x) + threadIdx.x;
  const int64_t stride = int64_t(gridDim.x) * blockDim.x;
  for (int64_t i = first; i < n4; i += stride)
    adamTable4(p, g, mv, p16, i, gmul, a);
  for (int64_t i = n4 * 4 + first; i < n; i += stride)
    adamTable1(p, g, mv, p16, i, gmul, a);
  const float scale = unscale / static_cast<float>(cnt);
  for (int64_t j = first; j < mlp.count; j += stride)
    adamMlpOne(mlp, j, scale, a);
}

/// Deterministic mode, after the training kernels: the fixed-point sums become the fp16 table gradient, the fp32
/// padded MLP gradient and the loss sum that Adam and the next step read; the fixed-point buffers are zeroed. A
/// non-finite loss (a diverging step) makes every gradient NaN, as the float atomics would.
__global__ void __launch_bounds__(256) fixedGradientKernel(Fixed* __restrict__ table, __half* __restrict__ g,
  int64_t n, Fixed* __restrict__ mlp, float* __restrict__ gradPad, int64_t nMlp, Counters* __restrict__ counters)
{
  // lossSum holds only non-finite contributions until it is written below (with a finite value), so every thread
  // sees the same verdict whether it reads before or after that write.
  const bool bad = !isfinite(counters->lossSum);
  const int64_t first = blockIdx.x * int64_t(blockDim.x) + threadIdx.x;
  const int64_t stride = int64_t(gridDim.x) * blockDim.x;
  const float nan = __int_as_float(0x7fc00000);
  for (int64_t i = first; i < n; i += stride)
  {
    g[i] = __float2half_rn(bad ? nan : fromFixed(table[i]));
    table[i] = 0ull;
  }
  for (int64_t j = first; j < nMlp; j += stride)
  {
    gradPad[j] = bad ? nan : fromFixed(mlp[j]);
    mlp[j] = 0ull;
  }
  if (first == 0 && !bad)
    counters->lossSum = static_cast<double>(static_cast<long long>(counters->lossFixed)) / kLossFixedScale;
}

} // namespace
} // namespace gpu
} // namespace nv
