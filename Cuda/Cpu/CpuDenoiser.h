// NeuralVolume engine: the CPU loop of the path-tracing denoiser (the per-pixel math: Core/Denoise.h).
#pragma once

#include "Core/Denoise.h"

#include <vector>

namespace nv
{

class ThreadPool;

class CpuDenoiser
{
public:
  /// out (width x height x 4) = the denoised `noisy` image, guided by `guide` (the ray-marched picture of the same
  /// scene); `moments`: the accumulation's second moments per pixel (read with params.frames >= 2, may be null
  /// otherwise). `out` may not alias the inputs. The work buffers are kept for the next call.
  void denoise(ThreadPool& pool, const DenoiseParams& params, const float* noisy, const float* guide,
    const float* moments, float* out);

private:
  std::vector<float> Illum[2];
  std::vector<float> Variance[2];
  std::vector<float> RawVariance; ///< the demodulated variance before filtering (the shrinkage towards the raw)
};

} // namespace nv
