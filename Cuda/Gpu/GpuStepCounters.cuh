// NeuralVolume engine: the per-step counters of the GPU trainer (loss sum, valid samples, the fused kernels' work
// tickets) and the device helpers that read and fill them.
#pragma once

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

} // namespace
} // namespace gpu
} // namespace nv
