// NeuralVolume engine: device helpers shared by the GPU render kernels (counters, pixel output).
#pragma once

#include "Core/RayMachine.h"
#include "GpuCommon.cuh"

namespace nv
{
namespace gpu
{

/// Sample Streaming's wavefront loop, driven on the device (GpuStreamingLoop.cuh): each batch takes up to `batch`
/// rays of the current live list from `start` on; after the list's last batch the lists swap.
struct StreamLoopState
{
  unsigned int live[2]; ///< rays in each live list (the other list fills with the rays the batches keep)
  unsigned int list;    ///< the list the current wavefront consumes
  unsigned int start;   ///< first ray of the current batch in it
  unsigned int points;  ///< queries the current batch emitted (the inference's device-side count)
  unsigned int more;    ///< after a batch: 1 while rays are live (the loop's condition)
};

/// Per-render counters (device).
struct RenderCounters
{
  unsigned long long evaluated; ///< field evaluations
  unsigned long long plain;     ///< samples a plain marcher would take
  unsigned int maxMajorantBits; ///< float bits of the largest cell majorant (non-negative: ordered as integers)
  unsigned int nextRay;         ///< In-Shader: next ray to hand out
  StreamLoopState loop;         ///< Sample Streaming: the loop's state (reset per sample)
  unsigned int batches;         ///< Sample Streaming: batches with live rays (RenderStats::wavefronts)
  unsigned int truncated;       ///< Sample Streaming: the loop stopped at its safety bound with rays live
};

/// Sum of a per-lane value over the warp (all lanes must call), added once to a 64-bit counter.
__device__ __forceinline__ void warpAdd(unsigned long long* counter, unsigned long long v)
{
  for (int o = 16; o > 0; o >>= 1)
    v += __shfl_xor_sync(0xffffffffu, v, o);
  if ((threadIdx.x & 31) == 0 && v)
    atomicAdd(counter, v);
}

/// A finished ray's colour into the image (ray-marching modes) or the accumulation buffer (path tracing).
__device__ __forceinline__ void writePixel(const ray::Ray& r, float4* image, float4* accum)
{
  float c[4];
  ray::result(r, c);
  const float4 v = make_float4(c[0], c[1], c[2], c[3]);
  if (accum)
  {
    float4 a = accum[r.pixel];
    accum[r.pixel] = make_float4(a.x + v.x, a.y + v.y, a.z + v.z, a.w + v.w);
  }
  else
  {
    image[r.pixel] = v;
  }
}

} // namespace gpu
} // namespace nv
