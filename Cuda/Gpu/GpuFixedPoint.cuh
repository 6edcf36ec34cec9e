// NeuralVolume engine: deterministic GPU training (TrainConfig::deterministic). The training kernels add their
// gradient contributions with atomics, whose order changes from run to run; with float atomics the sums then
// differ in their last bits and training drifts apart. In deterministic mode the table and MLP gradients and the
// loss are summed in 64-bit fixed point instead: integer addition is associative, so any order gives the same
// bits. A conversion kernel then writes the fp16 table gradient and the fp32 MLP gradient that Adam reads.
#pragma once

#include <cuda_fp16.h>

#include <cstdint>

namespace nv
{
namespace gpu
{

using Fixed = unsigned long long; ///< two's complement int64 in the storage type of atomicAdd

/// Gradients: 2^24 steps per unit, i.e. a resolution of 6e-8 (the smallest fp16 subnormal, the precision the
/// fp16 table gradient has anyway) and a range of +-5.5e11 per entry.
constexpr float kGradFixedScale = 16777216.0f;
/// Loss sums: 2^32 steps per unit (a step's loss sum is at most the batch size for normalised values).
constexpr double kLossFixedScale = 4294967296.0;

/// Fixed-point value of v (scale applied); saturates far beyond any gradient (|v| >= 2^38 after scaling by 2^24).
__device__ __forceinline__ long long toFixed(float v)
{
  const float s = fminf(fmaxf(v * kGradFixedScale, -4.6e18f), 4.6e18f);
  return __float2ll_rn(s);
}

__device__ __forceinline__ void fixedAdd(Fixed* p, float v)
{
  if (v != 0.0f)
    atomicAdd(p, static_cast<Fixed>(toFixed(v)));
}

__device__ __forceinline__ float fromFixed(Fixed f)
{
  return __ll2float_rn(static_cast<long long>(f)) * (1.0f / kGradFixedScale);
}

/// p[0..F) += v in fixed point (the deterministic counterpart of atomicAddVec).
template <int F>
__device__ __forceinline__ void atomicAddVec(Fixed* p, const float* v)
{
#pragma unroll
  for (int f = 0; f < F; ++f)
    fixedAdd(p + f, v[f]);
}

} // namespace gpu
} // namespace nv
