#include "GpuDenoiser.cuh"

#include "Core/Error.h"
#include "GpuInternal.cuh"

namespace nv
{
namespace gpu
{

namespace
{
const float* floats(const float4* p)
{
  return reinterpret_cast<const float*>(p);
}

float* floats(float4* p)
{
  return reinterpret_cast<float*>(p);
}

__global__ void frameMomentKernel(const float4* __restrict__ before, const float4* __restrict__ after, int64_t n,
  float framePaths, float* __restrict__ moments)
{
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
  {
    const float4 b = before[i], a = after[i];
    const float bv[4] = { b.x, b.y, b.z, b.w }, av[4] = { a.x, a.y, a.z, a.w };
    denoise::addFrameMoment(bv, av, framePaths, moments[i]);
  }
}

/// total[0]: the sum of the covered pixels' variances of the mean; total[1]: how many pixels the volume covers.
__global__ void rawVarianceKernel(DenoiseParams p, const float* __restrict__ noisy, const float* __restrict__ guide,
  const float* __restrict__ moments, float* __restrict__ total)
{
  const int64_t n = int64_t(p.width) * p.height;
  float sum = 0.0f, covered = 0.0f;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
    if (denoise::guideCovers(p, guide + 4 * i))
    {
      sum += denoise::rawVarianceOfMean(p, noisy + 4 * i, moments[i]);
      covered += 1.0f;
    }
  for (int offset = 16; offset > 0; offset /= 2)
  {
    sum += __shfl_down_sync(0xffffffffu, sum, offset);
    covered += __shfl_down_sync(0xffffffffu, covered, offset);
  }
  if ((threadIdx.x & 31) == 0)
  {
    atomicAdd(total, sum);
    atomicAdd(total + 1, covered);
  }
}

__global__ void demodulateKernel(DenoiseParams p, const float* __restrict__ noisy, const float* __restrict__ guide,
  const float* __restrict__ moments, float* __restrict__ illum, float* __restrict__ variance)
{
  const int64_t n = int64_t(p.width) * p.height;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
    denoise::demodulate(p, noisy + 4 * i, guide + 4 * i, moments ? moments[i] : 0.0f, illum + 4 * i, variance[i]);
}

__global__ void spatialVarianceKernel(DenoiseParams p, const float* __restrict__ illum, float* __restrict__ variance)
{
  const int64_t n = int64_t(p.width) * p.height;
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
    if (variance[i] < 0.0f)
      variance[i] = denoise::spatialVariance(p, int(i % p.width), int(i / p.width), illum);
}

__global__ void atrousKernel(DenoiseParams p, int step, const float* __restrict__ illum,
  const float* __restrict__ variance, const float* __restrict__ guide, float* __restrict__ illumOut,
  float* __restrict__ varianceOut)
{
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < p.width && y < p.height)
    denoise::atrousPixel(p, x, y, step, illum, variance, guide, illumOut, varianceOut);
}

/// total: step 4's sum of the covered pixels' variances of the mean and their count (null: no fade).
__global__ void remodulateKernel(DenoiseParams p, const float* noisy, const float* __restrict__ guide,
  const float* __restrict__ illum, const float* __restrict__ rawVariance, const float* __restrict__ total, float* out)
{
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (total)
    p.rawFade = total[1] > 0.0f ? denoise::fade(p, double(total[0]) / double(total[1])) : 0.0f;
  if (x < p.width && y < p.height)
    denoise::remodulate(p, x, y, noisy, guide, illum, rawVariance, out);
}
} // namespace

void GpuDenoiser::addFrameMoments(const float4* before, const float4* after, int64_t pixels, float framePaths,
  float* moments, cudaStream_t stream)
{
  frameMomentKernel<<<gridFor(pixels), 256, 0, stream>>>(before, after, pixels, framePaths, moments);
  NV_CUDA_LAUNCH();
}

void GpuDenoiser::denoise(const DenoiseParams& params, const float4* noisy, const float4* guide, const float* moments,
  float4* out, cudaStream_t stream)
{
  DenoiseParams p = params;
  NV_CHECK(p.width > 0 && p.height > 0, "denoise: the image is empty");
  NV_CHECK(p.iterations >= 0 && p.iterations <= 10, "denoise: 0..10 a-trous iterations");
  NV_CHECK(p.frames < 2 || moments, "denoise: an accumulation of several frames needs its moments");
  const int64_t pixels = int64_t(p.width) * p.height;
  for (int b = 0; b < 2; ++b)
    if (Illum[b].size() < size_t(pixels))
    {
      Illum[b].allocate(size_t(pixels), "denoiser illumination");
      Variance[b].allocate(size_t(pixels), "denoiser variance");
    }
  if (RawVariance.size() < size_t(pixels))
    RawVariance.allocate(size_t(pixels), "denoiser raw variance");
  if (out == noisy)
  {
    if (NoisyCopy.size() < size_t(pixels))
      NoisyCopy.allocate(size_t(pixels), "denoiser input copy");
    NV_CUDA(cudaMemcpyAsync(NoisyCopy.get(), noisy, size_t(pixels) * sizeof(float4), cudaMemcpyDeviceToDevice,
      stream));
    noisy = NoisyCopy.get();
  }
  demodulateKernel<<<gridFor(pixels), 256, 0, stream>>>(p, floats(noisy), floats(guide), p.frames >= 2 ? moments :
    nullptr, floats(Illum[0].get()), Variance[0].get());
  NV_CUDA_LAUNCH();
  if (p.frames < 2)
  {
    spatialVarianceKernel<<<gridFor(pixels), 256, 0, stream>>>(p, floats(Illum[0].get()), Variance[0].get());
    NV_CUDA_LAUNCH();
  }
  NV_CUDA(cudaMemcpyAsync(RawVariance.get(), Variance[0].get(), size_t(pixels) * sizeof(float),
    cudaMemcpyDeviceToDevice, stream));
  // Step 4's estimate: the mean variance of the raw mean, summed on the GPU; the remodulation computes the fade from
  // it (nothing waits for the GPU here).
  p.rawFade = 0.0f;
  const float* total = nullptr;
  if (p.frames >= 2)
  {
    if (!Total.get())
      Total.allocate(2, "denoiser sum");
    NV_CUDA(cudaMemsetAsync(Total.get(), 0, 2 * sizeof(float), stream));
    rawVarianceKernel<<<gridFor(pixels), 256, 0, stream>>>(p, floats(noisy), floats(guide), moments, Total.get());
    NV_CUDA_LAUNCH();
    total = Total.get();
  }
  const dim3 block(16, 16), grid((p.width + 15) / 16, (p.height + 15) / 16);
  int cur = 0;
  for (int it = 0; it < p.iterations; ++it)
  {
    atrousKernel<<<grid, block, 0, stream>>>(p, 1 << it, floats(Illum[cur].get()), Variance[cur].get(),
      floats(guide), floats(Illum[cur ^ 1].get()), Variance[cur ^ 1].get());
    NV_CUDA_LAUNCH();
    cur ^= 1;
  }
  remodulateKernel<<<grid, block, 0, stream>>>(p, floats(noisy), floats(guide), floats(Illum[cur].get()),
    RawVariance.get(), total, floats(out));
  NV_CUDA_LAUNCH();
}

int64_t GpuDenoiser::deviceMemoryBytes() const
{
  return static_cast<int64_t>(Illum[0].bytes() + Illum[1].bytes() + Variance[0].bytes() + Variance[1].bytes() +
    RawVariance.bytes() + NoisyCopy.bytes());
}

} // namespace gpu
} // namespace nv
