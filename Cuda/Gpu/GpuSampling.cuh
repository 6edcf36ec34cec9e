// NeuralVolume engine: the training targets of a GPU step: samples of a GPU-resident volume (uniform or by the
// importance draw) or points of a bank, drawn as the CPU trainer draws them.
#pragma once

#include "Core/TrainingPoints.h"
#include "Core/ValueRange.h"
#include "Cpu/CpuSampler.h"
#include "GpuImportance.cuh"
#include "GpuStepCounters.cuh"

namespace nv
{
namespace gpu
{
namespace
{

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

} // namespace
} // namespace gpu
} // namespace nv
