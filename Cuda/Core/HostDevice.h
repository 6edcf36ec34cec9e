// NeuralVolume engine: qualifiers for functions shared by the CPU and CUDA implementations.
#pragma once

#if defined(__CUDACC__)
#define NV_HD __host__ __device__ __forceinline__
#else
#define NV_HD inline
#endif

// NV_HD_INLINE: a named step of a hot host-device function (the ray machine's consume()): always inlined on the
// host too, so that splitting a function into steps leaves the generated code as it was.
#if defined(__CUDACC__)
#define NV_HD_INLINE __host__ __device__ __forceinline__
#elif defined(__GNUC__) || defined(__clang__)
#define NV_HD_INLINE inline __attribute__((always_inline))
#else
#define NV_HD_INLINE inline
#endif
