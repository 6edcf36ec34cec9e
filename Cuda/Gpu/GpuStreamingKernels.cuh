// NeuralVolume engine: GPU kernels of Sample Streaming's wavefront loop. Every kernel reads the loop's state
// (StreamLoopState: which live list, which batch of it, how many queries the batch emitted) from device memory, so
// the host enqueues a batch without knowing its size: the loop runs on the device (GpuStreamingLoop.cu). A batch:
// emitPackKernel (queries of the next K steps of its rays, packed) -> inference on the device-side count ->
// consumeKernel (rays advance; finished ones write their pixel, the others go to the next list) ->
// advanceKernel (next batch or next wavefront; the loop's condition). Included by GpuStreamingLoop.cu only.
#pragma once

#include "GpuRenderCommon.cuh"

#include <cuda_runtime.h>

namespace nv
{
namespace gpu
{

/// The current batch of the live list: its first ray's index in the list and its number of rays (0: none).
__device__ __forceinline__ uint32_t currentBatch(const StreamLoopState& s, uint32_t batch)
{
  const uint32_t live = s.live[s.list];
  return s.start < live ? min(batch, live - s.start) : 0u;
}

__global__ void initRaysKernel(const __grid_constant__ ray::Params P, uint32_t sample, ray::Ray* __restrict__ rays,
  uint32_t* __restrict__ active, RenderCounters* counters, float4* image, float4* accum)
{
  const int64_t pixels = int64_t(P.width) * P.height;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < pixels; i += int64_t(gridDim.x) * blockDim.x)
  {
    ray::Ray r;
    ray::initRay(P, static_cast<int>(i % P.width), static_cast<int>(i / P.width), r, sample);
    if (r.phase == ray::Done)
    {
      writePixel(r, image, accum);
      continue;
    }
    rays[i] = r;
    active[atomicAdd(&counters->loop.live[0], 1u)] = static_cast<uint32_t>(i);
  }
}

/// Queries of the next K steps of each ray of the batch (one emit per ray into its slot of `stride` points, so the
/// count and the queries come from the same evaluation), packed: the warp reserves its rays' queries with one atomic
/// on the batch's count and copies them together (coalesced). counts / offsets: per ray of the batch.
__global__ void __launch_bounds__(256) emitPackKernel(const __grid_constant__ ray::Params P,
  const ray::Ray* __restrict__ rays, const uint32_t* __restrict__ list0, const uint32_t* __restrict__ list1,
  RenderCounters* counters, uint32_t batch, int K, int stride, float* __restrict__ slots,
  uint32_t* __restrict__ counts, uint32_t* __restrict__ offsets, float* __restrict__ points)
{
  StreamLoopState& s = counters->loop;
  const uint32_t m = currentBatch(s, batch);
  const uint32_t* active = (s.list ? list1 : list0) + s.start;
  const int lane = threadIdx.x & 31;
  // Whole warps iterate together (the shuffles need every lane); m is the same for every thread.
  for (uint32_t base = blockIdx.x * blockDim.x + (threadIdx.x & ~31u); base < m; base += gridDim.x * blockDim.x)
  {
    const uint32_t i = base + lane;
    uint32_t n = 0;
    if (i < m)
      n = static_cast<uint32_t>(
        ray::emit(P, rays[active[i]], K, reinterpret_cast<ray::V3*>(slots) + size_t(i) * stride));
    uint32_t inclusive = n;
    for (int o = 1; o < 32; o <<= 1)
    {
      const uint32_t v = __shfl_up_sync(0xffffffffu, inclusive, o);
      if (lane >= o)
        inclusive += v;
    }
    uint32_t first = 0;
    if (lane == 31 && inclusive > 0)
      first = atomicAdd(&s.points, inclusive);
    first = __shfl_sync(0xffffffffu, first, 31);
    const uint32_t offset = first + inclusive - n;
    if (i < m)
    {
      counts[i] = n;
      offsets[i] = offset;
    }
    __syncwarp(); // the lanes' slots are written (and visible to the warp)
    for (int j = 0; j < 32; ++j)
    {
      const uint32_t nj = __shfl_sync(0xffffffffu, n, j), oj = __shfl_sync(0xffffffffu, offset, j);
      const float* src = slots + 3 * (size_t(base + j) * stride);
      float* dst = points + 3 * size_t(oj);
      for (uint32_t f = lane; f < 3 * nj; f += 32)
        dst[f] = src[f];
    }
  }
}

/// Consume each ray's values of the batch (those of queries outside the source's domain made NaN first, in place;
/// points: the packed queries); finished rays write their pixel, the others go to the other live list.
__global__ void __launch_bounds__(256) consumeKernel(const __grid_constant__ ray::Params P,
  ray::Ray* __restrict__ rays, uint32_t* list0, uint32_t* list1, uint32_t batch, int K,
  const uint32_t* __restrict__ counts, const uint32_t* __restrict__ offsets, const float* __restrict__ points,
  float* __restrict__ values, RenderCounters* counters, float4* image, float4* accum)
{
  StreamLoopState& s = counters->loop;
  const uint32_t m = currentBatch(s, batch);
  const uint32_t* active = (s.list ? list1 : list0) + s.start;
  uint32_t* next = s.list ? list0 : list1;
  unsigned int* nextCount = &s.live[s.list ^ 1u];
  unsigned long long evaluated = 0, plain = 0;
  const uint32_t stride = gridDim.x * blockDim.x;
  for (uint32_t base = blockIdx.x * blockDim.x; base < m; base += stride)
  {
    const uint32_t i = base + threadIdx.x;
    if (i < m)
    {
      const uint32_t id = active[i];
      ray::Ray r = rays[id];
      ray::maskOutsideDomain(P, reinterpret_cast<const ray::V3*>(points + 3 * size_t(offsets[i])), values + offsets[i],
        static_cast<int>(counts[i]));
      ray::consume(P, r, K, values + offsets[i], static_cast<int>(counts[i]));
      evaluated += counts[i];
      if (r.phase == ray::Done)
      {
        plain += r.plain;
        writePixel(r, image, accum);
      }
      else
      {
        rays[id] = r;
        next[atomicAdd(nextCount, 1u)] = id;
      }
    }
  }
  warpAdd(&counters->evaluated, evaluated);
  warpAdd(&counters->plain, plain);
}

/// After a batch (one thread): the next batch of the list, or -- after its last batch -- the other list (the rays
/// the wavefront kept). `more` (and, in a CUDA graph, the WHILE node's condition through `handle`) tells whether
/// rays are live. maxBatches: the safety bound (counters->truncated when reached with rays live).
__global__ void advanceKernel(RenderCounters* counters, uint32_t batch, uint32_t maxBatches,
  unsigned long long handle, int setCondition)
{
  if (blockIdx.x != 0 || threadIdx.x != 0)
    return;
  StreamLoopState& s = counters->loop;
  const uint32_t live = s.live[s.list];
  if (s.start < live)
    ++counters->batches;
  s.start += batch;
  s.points = 0;
  if (s.start >= live)
  {
    s.live[s.list] = 0; // emptied: it collects the next wavefront's kept rays
    s.list ^= 1u;
    s.start = 0;
  }
  uint32_t more = s.live[s.list] > 0 ? 1u : 0u;
  if (more && counters->batches >= maxBatches)
  {
    counters->truncated = 1;
    more = 0;
  }
  s.more = more;
#if CUDART_VERSION >= 12040
  if (setCondition)
    cudaGraphSetConditional(static_cast<cudaGraphConditionalHandle>(handle), more);
#else
  (void)handle;
  (void)setCondition;
#endif
}

} // namespace gpu
} // namespace nv
