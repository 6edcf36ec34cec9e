// NeuralVolume engine: gradient reductions that compile for every GPU from Turing (sm_75) on. Hopper and newer
// (sm_90+) reduce two or four values with one vector instruction; older GPUs issue the same additions one element
// (fp32) or one f16x2 pair (fp16) at a time. The sums are the same; only the number of L2 operations differs.
#pragma once

#include <cuda_fp16.h>

#include <cstdint>

namespace nv
{
namespace gpu
{

#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
#define NV_VECTOR_REDUCTIONS 1
#else
#define NV_VECTOR_REDUCTIONS 0
#endif

/// p[0..2) += (x, y); p 8-byte aligned.
__device__ __forceinline__ void atomicAddPair(float* p, float x, float y)
{
#if NV_VECTOR_REDUCTIONS
  atomicAdd(reinterpret_cast<float2*>(p), make_float2(x, y));
#else
  atomicAdd(p, x);
  atomicAdd(p + 1, y);
#endif
}

/// p[0..4) += (x, y, z, w); p 16-byte aligned.
__device__ __forceinline__ void atomicAddQuad(float* p, float x, float y, float z, float w)
{
#if NV_VECTOR_REDUCTIONS
  atomicAdd(reinterpret_cast<float4*>(p), make_float4(x, y, z, w));
#else
  atomicAdd(p, x);
  atomicAdd(p + 1, y);
  atomicAdd(p + 2, z);
  atomicAdd(p + 3, w);
#endif
}

/// p[0..2) += one packed f16x2 pair (sm_60+).
__device__ __forceinline__ void reduceHalfPair(__half* p, uint32_t h01)
{
  asm volatile("red.global.add.noftz.f16x2 [%0], %1;\n" ::"l"(p), "r"(h01) : "memory");
}

/// p[0..4) += two packed f16x2 pairs; p 8-byte aligned.
__device__ __forceinline__ void reduceHalfPairs2(__half* p, uint32_t h01, uint32_t h23)
{
#if NV_VECTOR_REDUCTIONS
  asm volatile("red.global.add.noftz.v2.f16x2 [%0], {%1, %2};\n" ::"l"(p), "r"(h01), "r"(h23) : "memory");
#else
  reduceHalfPair(p, h01);
  reduceHalfPair(p + 2, h23);
#endif
}

/// p[0..8) += four packed f16x2 pairs; p 16-byte aligned.
__device__ __forceinline__ void reduceHalfPairs4(__half* p, uint32_t h01, uint32_t h23, uint32_t h45, uint32_t h67)
{
#if NV_VECTOR_REDUCTIONS
  asm volatile("red.global.add.noftz.v4.f16x2 [%0], {%1, %2, %3, %4};\n" ::"l"(p), "r"(h01), "r"(h23), "r"(h45),
    "r"(h67)
               : "memory");
#else
  reduceHalfPairs2(p, h01, h23);
  reduceHalfPairs2(p + 4, h45, h67);
#endif
}

#undef NV_VECTOR_REDUCTIONS

} // namespace gpu
} // namespace nv
