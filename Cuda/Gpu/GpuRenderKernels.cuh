// NeuralVolume engine: GPU kernels of the renderer other than In-Shader and Sample Streaming (GpuStreamingKernels.cuh):
// macrocells, the Decode path (the ray machine over a 3D texture of the decoded grid) and image accumulation. They
// run the shared ray machine (Core/RayMachine.h).
// Included by GpuRenderer.cu only (the kernels are defined here).
#pragma once

#include "Core/Macrocells.h"
#include "GpuRenderCommon.cuh"

namespace nv
{
namespace gpu
{

// ---------------------------------------------------------------------------------------------------------
// Macrocells

/// occupancy (a sparse source's, device memory; null: every cell): cells without the bit hold `background` exactly.
__global__ void cellRangeKernel(MacrocellLayout m, const float* __restrict__ lattice, int64_t lx, int64_t ly,
  int64_t lz, float margin, const uint32_t* __restrict__ occupancy, float background, float2* __restrict__ range)
{
  const int cells = m.dims[0] * m.dims[1] * m.dims[2];
  const int64_t L[3] = { lx, ly, lz };
  for (int c = blockIdx.x * blockDim.x + threadIdx.x; c < cells; c += gridDim.x * blockDim.x)
  {
    if (occupancy && !cellBit(occupancy, c))
    {
      range[c] = make_float2(background, background);
      continue;
    }
    const int cx = c % m.dims[0], cy = (c / m.dims[0]) % m.dims[1], cz = c / (m.dims[0] * m.dims[1]);
    float lo, hi;
    cellRange(m, lattice, L, cx, cy, cz, margin, lo, hi);
    range[c] = make_float2(lo, hi);
  }
}

__global__ void majorantKernel(const float2* __restrict__ range, int cells, const float* __restrict__ tf,
  int tfSize, float scale, float shift, float* __restrict__ majorant, RenderCounters* counters)
{
  for (int c = blockIdx.x * blockDim.x + threadIdx.x; c < cells; c += gridDim.x * blockDim.x)
  {
    const float2 r = range[c];
    const float m = rangeMajorant(tf, tfSize, scale, shift, r.x, r.y);
    majorant[c] = m;
    atomicMax(&counters->maxMajorantBits, __float_as_uint(m));
  }
}

// ---------------------------------------------------------------------------------------------------------
// Decode path: the ray machine over the decoded grid (hardware trilinear filtering of a float 3D texture)

/// Field value at network coordinates u: voxel i sits at i / (n - 1), texel centres at i + 1/2.
__device__ __forceinline__ float gridValue(cudaTextureObject_t tex, float nx, float ny, float nz, ray::V3 u)
{
  return tex3D<float>(tex, u.x * nx + 0.5f, u.y * ny + 0.5f, u.z * nz + 0.5f);
}

__global__ void __launch_bounds__(256) marchGridKernel(const __grid_constant__ ray::Params P, cudaTextureObject_t tex,
  float nx1, float ny1, float nz1, uint32_t sample, float4* image, float4* accum, RenderCounters* counters)
{
  const int64_t pixels = int64_t(P.width) * P.height;
  unsigned long long evaluated = 0, plain = 0;
  const int64_t stride = int64_t(gridDim.x) * blockDim.x;
  // Whole warps iterate together (the counters' warp reductions need every lane).
  for (int64_t base = int64_t(blockIdx.x) * blockDim.x; base < pixels; base += stride)
  {
    const int64_t i = base + threadIdx.x;
    if (i < pixels)
    {
      ray::Ray r;
      ray::initRay(P, static_cast<int>(i % P.width), static_cast<int>(i / P.width), r, sample);
      ray::V3 q[ray::kMaxQueriesPerStep];
      float v[ray::kMaxQueriesPerStep];
      for (int guard = 0; r.phase != ray::Done && guard < ray::kMaxIterations; ++guard)
      {
        const int n = ray::emit(P, r, 1, q);
        for (int k = 0; k < n; ++k)
          v[k] = gridValue(tex, nx1, ny1, nz1, q[k]);
        ray::maskOutsideDomain(P, q, v, n);
        ray::consume(P, r, 1, v, n);
        evaluated += n;
      }
      plain += r.plain;
      writePixel(r, image, accum);
    }
  }
  warpAdd(&counters->evaluated, evaluated);
  warpAdd(&counters->plain, plain);
}

// ---------------------------------------------------------------------------------------------------------
// Path tracing

/// image = accum / frames (path tracing).
__global__ void resolveKernel(const float4* __restrict__ accum, int64_t n, float inv, float4* __restrict__ image)
{
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
  {
    const float4 a = accum[i];
    image[i] = make_float4(a.x * inv, a.y * inv, a.z * inv, a.w * inv);
  }
}

} // namespace gpu
} // namespace nv
