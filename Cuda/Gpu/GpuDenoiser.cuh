// NeuralVolume engine: the CUDA kernels of the path-tracing denoiser (the per-pixel math: Core/Denoise.h, shared with
// Cpu/CpuDenoiser.cpp).
#pragma once

#include "Core/Denoise.h"
#include "GpuCommon.cuh"

#include <cstdint>

namespace nv
{
namespace gpu
{

class GpuDenoiser
{
public:
  /// out (device, width x height) = the denoised `noisy` image guided by `guide` (the ray-marched picture of the same
  /// scene), all in device memory, enqueued on `stream`; `moments` (device, per pixel) is read with params.frames >= 2.
  /// `out` may be `noisy` itself (it is copied first). The work buffers are kept for the next call.
  void denoise(const DenoiseParams& params, const float4* noisy, const float4* guide, const float* moments,
    float4* out, cudaStream_t stream);

  /// moments[i] += framePaths x luminance(frame mean)^2, the frame being after[i] - before[i] (accumulated sums).
  static void addFrameMoments(const float4* before, const float4* after, int64_t pixels, float framePaths,
    float* moments, cudaStream_t stream);

  int64_t deviceMemoryBytes() const;

private:
  DeviceBuffer<float4> Illum[2];
  DeviceBuffer<float> Variance[2];
  DeviceBuffer<float> Total;       ///< step 4: the sum of the pixels' variances of the mean
  DeviceBuffer<float4> NoisyCopy;  ///< `noisy` when the output overwrites it (remodulation reads neighbours)
  DeviceBuffer<float> RawVariance; ///< the demodulated variance before filtering (the shrinkage towards the raw)
};

} // namespace gpu
} // namespace nv
