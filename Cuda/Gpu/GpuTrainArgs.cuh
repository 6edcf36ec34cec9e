// NeuralVolume engine: arguments of the GPU training kernels (GpuTrainWmma.cuh, GpuTrainRegKernel.cuh).
#pragma once

#include "GpuAdam.cuh"
#include "GpuSampling.cuh"
#include "GpuStepCounters.cuh"

namespace nv
{
namespace gpu
{

/// Shared-memory plan of the register-resident training kernel (GpuTrainRegKernel.cuh); warps == 0: not usable.
struct RegPlan
{
  int warps;
  int ldX0, ldA, ldDE;  ///< leading dimensions: X_0 (halves), X_l / dZ_l (halves), fused dEnc (floats)
  int weights[kMaxHidden];          ///< layer weights W_l, offsets in halves
  int layerInputs[kMaxHidden];      ///< staging of each layer's input X_l (T rows), halves
  int layerOutputGrads[kMaxHidden]; ///< staging of each layer's output gradient dZ_l (T rows), halves
  int wout, encodingGrads, total;   ///< bytes: fp32 output row, fused-mode dEnc (16 rows per warp), block total
};

struct TrainArgs
{
  GridLayout grid;
  MlpShape shape;
  SmemPlan plan; ///< WMMA kernel
  int actOff[kMaxHidden]; ///< WMMA kernel: offset (halves) of X_l, the input of hidden layer l >= 1, in the activations
  RegPlan reg;   ///< register-resident kernel
  const __half* table16; ///< WMMA kernel: the fp16 copy of the table
  const float* table32;  ///< register-resident kernel: the fp32 parameters (fused mode encodes from them)
  const __half* w16;
  const float* wout;
  __half* gradTable; ///< fp16, unscaled (Adam applies 1 / valid samples)
  float* slots;
  float* gradPad;
  Fixed* fixedTable; ///< deterministic mode: the table gradient in fixed point (instead of gradTable), else null
  Fixed* fixedMlp;   ///< deterministic mode: the padded MLP gradient and the loss in fixed point, else null
  const float* xyz; ///< null: randomPoint(seed, step, i)
  uint64_t seed, step;
  const float* targets; ///< NaN = invalid sample
  int64_t sampleCount;
  int tiles;
  int l1;
  Counters* counters;     ///< this step's
  const Counters* prev;   ///< the previous step's (loss-gradient scale), or null
  const __half* encG; ///< two-pass: encodings from encodeLevelsKernel (level-major)
  float* dEncG;       ///< two-pass: dL/d(encoding), level-major fp32 (scatter pass)
};

/// Adds one warp's loss sum to the step's counters: a double atomic, or in deterministic mode a fixed-point one (a
/// non-finite sum still goes to lossSum, so that a diverging step is seen whatever the mode).
__device__ __forceinline__ void addLoss(const TrainArgs& a, float lossAcc)
{
  if (lossAcc == 0.0f)
    return;
  if (a.fixedMlp && isfinite(lossAcc))
    atomicAdd(&a.counters->lossFixed, static_cast<Fixed>(__double2ll_rn(static_cast<double>(lossAcc) * kLossFixedScale)));
  else
    atomicAdd(&a.counters->lossSum, static_cast<double>(lossAcc));
}

/// The step's loss-gradient scale, published to the counters by the grid's first thread.
__device__ __forceinline__ float publishGradScale(const TrainArgs& a)
{
  const float gradScale = lossGradScale(a.prev, a.l1);
  if (blockIdx.x == 0 && threadIdx.x == 0)
    a.counters->gradScale = gradScale;
  return gradScale;
}

/// The warp's loss, summed over its lanes and added once (lane 0).
__device__ __forceinline__ void addWarpLoss(const TrainArgs& a, int lane, float lossAcc)
{
  for (int o = 16; o > 0; o >>= 1)
    lossAcc += __shfl_xor_sync(0xffffffffu, lossAcc, o);
  if (lane == 0)
    addLoss(a, lossAcc);
}

} // namespace gpu
} // namespace nv
