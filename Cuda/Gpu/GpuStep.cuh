// NeuralVolume engine: step counters, target sampling (GPU-resident volume) and the Adam kernels of the GPU
// trainer (hash table: one memory-bound pass that also writes the fp16 copy and zeroes the gradient; MLP:
// unpadded parameters from the padded gradient).
#pragma once

#include "Core/TrainingPoints.h"
#include "Core/ValueRange.h"
#include "Cpu/CpuSampler.h"
#include "GpuImportance.cuh"
#include "GpuNetwork.cuh"

namespace nv
{
namespace gpu
{
namespace
{

/// Per-step counters, zeroed before each step: loss sum, valid samples, and the work ticket / per-level done
/// counts of the fused scatter + Adam kernel (GpuScatterAdam.cuh).
struct Counters
{
  double lossSum;
  int nValid;
  int ticket;
  float gradScale; ///< loss-gradient scale of the step (set by the training kernel, read by Adam)
  int done[kMaxLevels];
  Fixed lossFixed; ///< deterministic mode: the finite part of the loss sum (kLossFixedScale); non-finite parts go
                   ///< to lossSum, and fixedGradientKernel makes lossSum the total
};

/// Loss-gradient scale of a step from the previous step's counters. The table gradient is accumulated in fp16 (and
/// dZ is fp16): with L2 the raw gradient 2 (o - t) shrinks with the residual until its contributions leave fp16's
/// normal range, so it is multiplied by the power of two at or below 1 / (2 rms residual) of the previous step
/// (1..4096), the scale of the L1 gradient (+-1); Adam divides it out. L1: 1. Computed on the device, so queued
/// steps need no host round trip.
__device__ __forceinline__ float lossGradScale(const Counters* prev, int l1)
{
  if (l1 || !prev || prev->nValid <= 0 || !(prev->lossSum > 0.0))
    return 1.0f;
  const float k = 0.5f * rsqrtf(static_cast<float>(prev->lossSum / prev->nValid));
  return exp2f(fminf(12.0f, fmaxf(0.0f, floorf(log2f(k)))));
}

/// Adds a thread's count of valid targets to the step's counter (one atomic per warp).
__device__ __forceinline__ void addValid(int local, Counters* counters)
{
  for (int o = 16; o > 0; o >>= 1)
    local += __shfl_xor_sync(0xffffffffu, local, o);
  if ((threadIdx.x & 31) == 0 && local)
    atomicAdd(&counters->nValid, local);
}

/// Targets of step `step` at randomPoint's uniform points, or (imp.cdf set) at the importance draw's points, whose
/// positions then go to imp.xyz for the training kernel.
template <typename T>
__global__ void sampleKernel(const T* __restrict__ vol, int64_t d0, int64_t d1, int64_t d2, ValueRange range,
  uint64_t seed, uint64_t step, int64_t n, float* __restrict__ targets, Counters* counters, ImportanceDraw imp)
{
  const int64_t dims[3] = { d0, d1, d2 };
  int local = 0;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
  {
    float x[3];
    if (imp.cdf)
    {
      importancePoint(imp.cdf, imp.cells, imp.invCells, seed, step, static_cast<uint64_t>(i), x);
      imp.xyz[3 * i] = x[0];
      imp.xyz[3 * i + 1] = x[1];
      imp.xyz[3 * i + 2] = x[2];
    }
    else
    {
      randomPoint(seed, step, static_cast<uint64_t>(i), x);
    }
    auto get = [&](int64_t k) { return static_cast<float>(range.normalize(static_cast<double>(vol[k]))); };
    float t = 0.0f;
    const bool ok = sampleTrilinear(get, dims, 0.0f, 1.0f, x, t);
    targets[i] = ok ? t : __int_as_float(0x7fc00000);
    local += ok ? 1 : 0;
  }
  addValid(local, counters);
}

/// A bank of training points: sample i of the step is bank point randomBankIndex(...) (the CPU trainer's draw);
/// positions into xyz, values into targets (NaN stays NaN: not trained on).
__global__ void gatherKernel(const float* __restrict__ bankXyz, const float* __restrict__ bankValues, int64_t count,
  uint64_t seed, uint64_t step, int64_t n, float* __restrict__ xyz, float* __restrict__ targets, Counters* counters)
{
  int local = 0;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
  {
    const int64_t k = randomBankIndex(seed, step, static_cast<uint64_t>(i), count);
    xyz[3 * i] = bankXyz[3 * k];
    xyz[3 * i + 1] = bankXyz[3 * k + 1];
    xyz[3 * i + 2] = bankXyz[3 * k + 2];
    const float t = bankValues[k];
    const bool ok = finiteValue(t);
    targets[i] = ok ? t : __int_as_float(0x7fc00000);
    local += ok ? 1 : 0;
  }
  addValid(local, counters);
}

struct AdamArgs
{
  float b1, b2, a1, a2, eps, stepSize, invSqrtBc2;
  float stateScale; ///< hash-table moments are kept in units of stateScale x gradient (the batch size)
  uint32_t noise;   ///< per-step seed of the stochastic rounding of the table moments
};

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
  float* p;
  float* m;
  float* v;
  float* gradPad;
  __half* w16;
  float* wout;
  MlpShape s;
  int64_t count;
};

/// Adam for MLP parameter j (fp32 state): gradient from the padded accumulator (zeroed), fp16 padded copy out.
__device__ __forceinline__ void adamMlpOne(const MlpAdam& q, int64_t j, float scale, const AdamArgs& a)
{
  const MlpSlot m = mlpSlot(q.s, j);
  const int pi = m.padded;
  float pj = q.p[j], mj = q.m[j], vj = q.v[j], gj = q.gradPad[pi];
  adamOne(pj, gj, mj, vj, scale, a);
  q.p[j] = pj;
  q.m[j] = mj;
  q.v[j] = vj;
  q.gradPad[pi] = 0.0f;
  if (m.layer == q.s.H)
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
