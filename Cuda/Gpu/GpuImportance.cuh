// NeuralVolume engine: the GPU trainer's importance grid (Core/ImportanceGrid.h). Every kImportanceInterval steps
// the network (after the step's update) is evaluated on the step's batch; the absolute errors are summed per cell in
// fixed point (integer atomics: the same sums whatever the order) and one block folds them into the weights and
// rebuilds the integer CDF in place. sampleKernel then draws from that CDF. Nothing is allocated or uploaded per step.
#pragma once

#include "Core/ImportanceGrid.h"
#include "GpuCommon.cuh"

namespace nv
{
namespace gpu
{
namespace
{

/// Device state of the importance grid: cells^3 weights (NaN until measured), error sums, counts and the CDF.
struct GpuImportanceGrid
{
  int cells = 0;
  float invCells = 0.0f;
  DeviceBuffer<float> weights;
  DeviceBuffer<unsigned long long> sums;
  DeviceBuffer<unsigned int> counts;
  DeviceBuffer<uint64_t> cdf;
  DeviceBuffer<float> out; ///< the network's values at the batch points (refresh steps)

  bool enabled() const { return cells > 0; }

  void allocate(int c, int64_t batch, cudaStream_t st)
  {
    cells = c;
    invCells = 1.0f / static_cast<float>(c);
    const size_t n = static_cast<size_t>(c) * c * c;
    weights.allocate(n, "importance weights");
    sums.allocate(n, "importance error sums");
    counts.allocate(n, "importance counts");
    cdf.allocate(n, "importance CDF");
    out.allocate(static_cast<size_t>(batch), "importance probe values");
    NV_CUDA(cudaMemsetAsync(weights.get(), 0xff, weights.bytes(), st)); // NaN: never measured
    NV_CUDA(cudaMemsetAsync(sums.get(), 0, sums.bytes(), st));
    NV_CUDA(cudaMemsetAsync(counts.get(), 0, counts.bytes(), st));
    NV_CUDA(cudaMemsetAsync(cdf.get(), 0, cdf.bytes(), st)); // empty CDF: uniform points until the first refresh
  }

  size_t bytes() const { return weights.bytes() + sums.bytes() + counts.bytes() + cdf.bytes() + out.bytes(); }
};

/// What sampleKernel needs to draw importance points (cdf null: uniform points, xyz not written).
struct ImportanceDraw
{
  const uint64_t* cdf;
  int cells;
  float invCells;
  float* xyz; ///< the batch positions, written for the training kernel
};

/// Per-cell fixed-point sums of |values - targets| over the valid (finite-target) samples.
__global__ void importanceMeasureKernel(const float* __restrict__ xyz, const float* __restrict__ values,
  const float* __restrict__ targets, int64_t n, int cells, unsigned long long* __restrict__ sums,
  unsigned int* __restrict__ counts)
{
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
  {
    const float t = targets[i];
    if (!isfinite(t))
      continue;
    const float x[3] = { xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2] };
    const int c = importanceCell(x, cells);
    atomicAdd(&sums[c], static_cast<unsigned long long>(importanceFixedError(fabsf(values[i] - t))));
    atomicAdd(&counts[c], 1u);
  }
}

constexpr int kRefreshThreads = 1024;

/// One block: weights from the sums (which it zeroes), then the inclusive integer prefix sum of the quantised
/// weights (each thread a contiguous chunk; exact integer arithmetic, so the same CDF as the CPU's serial loop).
__global__ void __launch_bounds__(kRefreshThreads) importanceRefreshKernel(float* __restrict__ weights,
  unsigned long long* __restrict__ sums, unsigned int* __restrict__ counts, uint64_t* __restrict__ cdf,
  int n)
{
  __shared__ uint64_t partial[kRefreshThreads];
  const int t = threadIdx.x;
  const int per = (n + kRefreshThreads - 1) / kRefreshThreads;
  const int b = min(n, t * per), e = min(n, b + per);
  uint64_t run = 0;
  for (int c = b; c < e; ++c)
  {
    const float w = importanceUpdate(weights[c], sums[c], counts[c]);
    weights[c] = w;
    sums[c] = 0ull;
    counts[c] = 0u;
    run += importanceQuantize(w);
    cdf[c] = run;
  }
  partial[t] = run;
  __syncthreads();
  if (t == 0)
  {
    uint64_t acc = 0;
    for (int k = 0; k < kRefreshThreads; ++k)
    {
      const uint64_t v = partial[k];
      partial[k] = acc; // exclusive
      acc += v;
    }
  }
  __syncthreads();
  const uint64_t offset = partial[t];
  for (int c = b; c < e; ++c)
    cdf[c] += offset;
}

} // namespace
} // namespace gpu
} // namespace nv
