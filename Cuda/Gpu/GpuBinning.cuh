// NeuralVolume engine: spatial binning of point arrays before inference. Random points make the level-major encode
// L2-throughput bound (about five 32-byte sectors per sample and level, GpuLevels.cuh); after a counting sort by
// Morton bin, the samples of a block share the corners of the coarse and middle levels, which then come from L1.
// Each binned point carries its original index, where the MLP pass writes its output (FwdArgs::binned).
#pragma once

#include <cstdint>

namespace nv
{
namespace gpu
{

/// Spread the low 10 bits of v to every third bit.
__device__ __forceinline__ uint32_t spreadBits3(uint32_t v)
{
  v &= 0x3ffu;
  v = (v | (v << 16)) & 0x030000ffu;
  v = (v | (v << 8)) & 0x0300f00fu;
  v = (v | (v << 4)) & 0x030c30c3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}

/// Morton bin of a point of the unit cube on a 2^bits grid per axis (coordinates clamped; NaN goes to bin 0).
__device__ __forceinline__ uint32_t mortonBin(const float* p, int bits)
{
  const float s = static_cast<float>(1u << bits);
  uint32_t q[3];
#pragma unroll
  for (int k = 0; k < 3; ++k)
  {
    const float c = fminf(fmaxf(p[k] * s, 0.0f), s - 1.0f); // fmaxf(NaN, 0) = 0
    q[k] = static_cast<uint32_t>(c);
  }
  return spreadBits3(q[0]) | (spreadBits3(q[1]) << 1) | (spreadBits3(q[2]) << 2);
}

/// Points of a launch over a capacity of n: all n, or those of a device-side count (*liveCount - liveBase, clamped;
/// FwdArgs::liveCount).
__device__ __forceinline__ int64_t binnedPoints(int64_t n, const uint32_t* liveCount, int64_t liveBase)
{
  if (!liveCount)
    return n;
  const int64_t m = static_cast<int64_t>(*liveCount) - liveBase;
  return m < 0 ? 0 : (m > n ? n : m);
}

/// Pass 1: the rank of every point among the points of its bin (warp-aggregated atomic per bin).
__global__ void __launch_bounds__(256) binCountKernel(const float* __restrict__ xyz, int64_t capacity, int bits,
  uint32_t* __restrict__ counts, uint32_t* __restrict__ rank, const uint32_t* liveCount, int64_t liveBase)
{
  const int64_t n = binnedPoints(capacity, liveCount, liveBase);
  const int lane = threadIdx.x & 31;
  const int64_t stride = int64_t(gridDim.x) * blockDim.x;
  // Uniform trip count per warp so that the whole warp takes part in the match / shuffle.
  for (int64_t base = (blockIdx.x * int64_t(blockDim.x) + threadIdx.x) & ~int64_t(31); base < n; base += stride)
  {
    const int64_t i = base + lane;
    const bool valid = i < n;
    uint32_t bin = 0xffffffffu;
    if (valid)
    {
      const float p[3] = { xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2] };
      bin = mortonBin(p, bits);
    }
    const uint32_t group = __match_any_sync(0xffffffffu, bin);
    const int leader = __ffs(group) - 1;
    uint32_t first = 0;
    if (lane == leader && valid)
      first = atomicAdd(counts + bin, static_cast<uint32_t>(__popc(group)));
    first = __shfl_sync(0xffffffffu, first, leader);
    if (valid)
      rank[i] = first + __popc(group & ((1u << lane) - 1u));
  }
}

/// Pass 2 (after an exclusive scan of the counts into offsets): the points in bin order, each as one 16-byte
/// (x, y, z, original index as float bits) so that a point costs one sector to write.
__global__ void __launch_bounds__(256) binScatterKernel(const float* __restrict__ xyz, int64_t capacity, int bits,
  const uint32_t* __restrict__ rank, const uint32_t* __restrict__ offsets, float4* __restrict__ binned,
  const uint32_t* liveCount, int64_t liveBase)
{
  const int64_t n = binnedPoints(capacity, liveCount, liveBase);
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
  {
    const float p[3] = { xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2] };
    const uint32_t pos = offsets[mortonBin(p, bits)] + rank[i];
    binned[pos] = make_float4(p[0], p[1], p[2], __uint_as_float(static_cast<uint32_t>(i)));
  }
}

} // namespace gpu
} // namespace nv
