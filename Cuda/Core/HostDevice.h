// NeuralVolume engine: qualifiers for functions shared by the CPU and CUDA implementations.
#pragma once

#if defined(__CUDACC__)
#define NV_HD __host__ __device__ __forceinline__
#else
#define NV_HD inline
#endif
