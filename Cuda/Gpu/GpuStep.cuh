// NeuralVolume engine: step counters, target sampling (GPU-resident volume) and the Adam kernels of the GPU
// trainer (hash table: one memory-bound pass that also writes the fp16 copy and zeroes the gradient; MLP:
// unpadded parameters from the padded gradient).
#pragma once

#include "Cpu/CpuSampler.h"
#include "GpuNetwork.cuh"

namespace nv
{
namespace gpu
{
namespace
{

struct Counters
{
  double lossSum;
  int nValid;
  int pad;
};

template <typename T>
__global__ void sampleKernel(const T* __restrict__ vol, int64_t d0, int64_t d1, int64_t d2, double lo, double inv,
  uint64_t seed, uint64_t step, int64_t n, float* __restrict__ targets, Counters* counters)
{
  const int64_t dims[3] = { d0, d1, d2 };
  int local = 0;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
  {
    float x[3];
    randomPoint(seed, step, static_cast<uint64_t>(i), x);
    auto get = [&](int64_t k) { return static_cast<float>((static_cast<double>(vol[k]) - lo) * inv); };
    float t = 0.0f;
    const bool ok = sampleTrilinear(get, dims, 0.0f, 1.0f, x, t);
    targets[i] = ok ? t : __int_as_float(0x7fc00000);
    local += ok ? 1 : 0;
  }
  for (int o = 16; o > 0; o >>= 1)
    local += __shfl_xor_sync(0xffffffffu, local, o);
  if ((threadIdx.x & 31) == 0 && local)
    atomicAdd(&counters->nValid, local);
}

struct AdamArgs
{
  float b1, b2, a1, a2, eps, stepSize, invSqrtBc2;
};

__device__ __forceinline__ void adamOne(float& p, float& g, float& m, float& v, float scale, const AdamArgs& a)
{
  const float gi = g * scale;
  g = 0.0f;
  m = a.b1 * m + a.a1 * gi;
  v = a.b2 * v + a.a2 * gi * gi;
  p -= a.stepSize * m / (sqrtf(v) * a.invSqrtBc2 + a.eps);
}

/// One pass over the hash table: read p, g, m, v; write p, m, v, fp16 p; zero g.
__global__ void __launch_bounds__(256) adamTableKernel(float* __restrict__ p, float* __restrict__ g,
  float* __restrict__ m, float* __restrict__ v, __half* __restrict__ p16, int64_t n, AdamArgs a,
  const Counters* __restrict__ counters)
{
  const int cnt = counters->nValid;
  if (cnt == 0)
    return;
  const float scale = 1.0f / static_cast<float>(cnt);
  const int64_t n4 = n / 4;
  const int64_t stride = int64_t(gridDim.x) * blockDim.x;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n4; i += stride)
  {
    float4 P = reinterpret_cast<float4*>(p)[i];
    float4 G = reinterpret_cast<float4*>(g)[i];
    float4 M = reinterpret_cast<float4*>(m)[i];
    float4 V = reinterpret_cast<float4*>(v)[i];
    adamOne(P.x, G.x, M.x, V.x, scale, a);
    adamOne(P.y, G.y, M.y, V.y, scale, a);
    adamOne(P.z, G.z, M.z, V.z, scale, a);
    adamOne(P.w, G.w, M.w, V.w, scale, a);
    reinterpret_cast<float4*>(p)[i] = P;
    reinterpret_cast<float4*>(g)[i] = G;
    reinterpret_cast<float4*>(m)[i] = M;
    reinterpret_cast<float4*>(v)[i] = V;
    __align__(8) __half2 h[2] = { __floats2half2_rn(P.x, P.y), __floats2half2_rn(P.z, P.w) };
    reinterpret_cast<uint2*>(p16)[i] = *reinterpret_cast<const uint2*>(h);
  }
  for (int64_t i = n4 * 4 + blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += stride)
  {
    adamOne(p[i], g[i], m[i], v[i], scale, a);
    p16[i] = __float2half_rn(p[i]);
  }
}

/// MLP parameters (unpadded, Model layout): gradients from the padded accumulator, fp16 padded copy out.
__global__ void adamMlpKernel(float* __restrict__ p, float* __restrict__ m, float* __restrict__ v,
  float* __restrict__ gradPad, __half* __restrict__ w16, float* __restrict__ wout, MlpShape s, int64_t count,
  AdamArgs a, const Counters* __restrict__ counters)
{
  const int cnt = counters->nValid;
  if (cnt == 0)
    return;
  const float scale = 1.0f / static_cast<float>(cnt);
  for (int64_t j = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; j < count; j += int64_t(gridDim.x) * blockDim.x)
  {
    int64_t r = j;
    int l = 0;
    for (; l < s.H; ++l)
    {
      const int64_t sz = int64_t(s.W) * (l == 0 ? s.D : s.W);
      if (r < sz)
        break;
      r -= sz;
    }
    int pi;
    if (l == s.H)
    {
      pi = s.off[s.H] + static_cast<int>(r);
    }
    else
    {
      const int K = l == 0 ? s.D : s.W;
      pi = s.off[l] + static_cast<int>(r / K) * s.inDim(l) + static_cast<int>(r % K);
    }
    float pj = p[j], mj = m[j], vj = v[j], gj = gradPad[pi];
    adamOne(pj, gj, mj, vj, scale, a);
    p[j] = pj;
    m[j] = mj;
    v[j] = vj;
    gradPad[pi] = 0.0f;
    if (l == s.H)
      wout[r] = pj;
    else
      w16[pi] = __float2half_rn(pj);
  }
}

} // namespace
} // namespace gpu
} // namespace nv
