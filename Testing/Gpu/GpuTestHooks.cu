// NeuralVolume GPU tests and benchmarks: probes into the CUDA engine's internals (see GpuTestHooks.h).
#include "GpuTestHooks.h"

#include "Core/Model.h"
#include "Gpu/GpuDenoiser.cuh"
#include "Gpu/GpuEngine.h"
#include "Gpu/GpuInternal.cuh"

#include <algorithm>
#include <chrono>
#include <vector>

namespace nv
{
namespace gpu
{
namespace
{

__global__ void encodeTestKernel(GridLayout g, const __half* __restrict__ table, const float* __restrict__ xyz,
  int64_t n, float* __restrict__ out)
{
  const int64_t items = n * g.levels;
  for (int64_t it = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; it < items; it += int64_t(gridDim.x) * blockDim.x)
  {
    const int64_t s = it / g.levels;
    const int l = static_cast<int>(it % g.levels);
    const LevelInfo& lv = g.level[l];
    const float x[3] = { xyz[3 * s], xyz[3 * s + 1], xyz[3 * s + 2] };
    uint32_t corner[3];
    float frac[3];
    gridPosition(lv, x, corner, frac);
    float acc[kMaxFeatures] = {};
    for (int c = 0; c < 8; ++c)
    {
      const float w = cornerWeight(c, frac);
      const __half* e = table + size_t(cornerIndex(lv, c, corner)) * g.features;
      for (int f = 0; f < g.features; ++f)
        acc[f] += w * __half2float(e[f]);
    }
    for (int f = 0; f < g.features; ++f)
      out[s * g.levels * g.features + l * g.features + f] = acc[f];
  }
}

__global__ void randomPointsKernel(float* xyz, int64_t n)
{
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
    randomPoint(12345, 1, static_cast<uint64_t>(i), xyz + 3 * i);
}

} // namespace

void testEncode(const Model& model, const float* xyz, int64_t n, float* out)
{
  Stream st;
  DeviceModel dm;
  uploadModel(model, dm, st.get());
  const int64_t D = int64_t(dm.grid.levels) * dm.grid.features;
  DeviceBuffer<float> dx(3 * n), dy(n * D);
  NV_CUDA(cudaMemcpyAsync(dx.get(), xyz, dx.bytes(), cudaMemcpyHostToDevice, st.get()));
  encodeTestKernel<<<gridFor(n * dm.grid.levels), 256, 0, st.get()>>>(dm.grid, dm.table16.get(), dx.get(), n, dy.get());
  NV_CUDA_LAUNCH();
  NV_CUDA(cudaMemcpyAsync(out, dy.get(), dy.bytes(), cudaMemcpyDeviceToHost, st.get()));
  st.sync();
}

namespace
{
template <typename Fn>
double medianMs(int reps, cudaStream_t st, Fn&& fn)
{
  Event a, b;
  std::vector<float> ts;
  fn(); // warm-up
  fn();
  for (int r = 0; r < reps; ++r)
  {
    NV_CUDA(cudaEventRecord(a.get(), st));
    fn();
    NV_CUDA(cudaEventRecord(b.get(), st));
    NV_CUDA(cudaEventSynchronize(b.get()));
    float ms = 0;
    NV_CUDA(cudaEventElapsedTime(&ms, a.get(), b.get()));
    ts.push_back(ms);
  }
  std::sort(ts.begin(), ts.end());
  return ts[ts.size() / 2];
}
} // namespace

double benchInferKernel(const Model& model, int64_t n, int reps, const KernelOptions& options)
{
  Stream st;
  DeviceModel dm;
  uploadModel(model, dm, st.get());
  dm.options = options;
  DeviceBuffer<float> dx(3 * n), dy(n);
  randomPointsKernel<<<gridFor(n), 256, 0, st.get()>>>(dx.get(), n);
  NV_CUDA_LAUNCH();
  return medianMs(reps, st.get(), [&] { launchInference(dm, dx.get(), 0, 0, 0, 0, 0, n, dy.get(), st.get()); });
}

double benchDecodeKernel(const Model& model, int64_t nx, int64_t ny, int64_t nz, int reps,
  const KernelOptions& options)
{
  Stream st;
  DeviceModel dm;
  uploadModel(model, dm, st.get());
  dm.options = options;
  const int64_t n = nx * ny * nz;
  DeviceBuffer<float> dy(n);
  return medianMs(reps, st.get(), [&] { launchInference(dm, nullptr, nx, ny, nz, 0, 0, n, dy.get(), st.get()); });
}

namespace
{
template <typename Fn>
double medianWallMs(int reps, Fn&& fn)
{
  std::vector<double> ts;
  fn(); // warm-up
  for (int r = 0; r < reps; ++r)
  {
    const auto a = std::chrono::steady_clock::now();
    fn();
    ts.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count());
  }
  std::sort(ts.begin(), ts.end());
  return ts[ts.size() / 2];
}
} // namespace

void copyToHost(const float* device, size_t n, float* host, const void* ready)
{
  if (ready)
    NV_CUDA(cudaEventSynchronize(static_cast<cudaEvent_t>(const_cast<void*>(ready))));
  NV_CUDA(cudaMemcpy(host, device, n * sizeof(float), cudaMemcpyDeviceToHost));
}

void testDenoise(const DenoiseParams& params, const float* noisy, const float* guide, const float* moments,
  float* out)
{
  const size_t pixels = size_t(params.width) * size_t(params.height);
  DeviceBuffer<float4> dNoisy(pixels, "noisy"), dGuide(pixels, "guide"), dOut(pixels, "denoised");
  DeviceBuffer<float> dMoments(pixels, "moments");
  NV_CUDA(cudaMemcpy(dNoisy.get(), noisy, dNoisy.bytes(), cudaMemcpyHostToDevice));
  NV_CUDA(cudaMemcpy(dGuide.get(), guide, dGuide.bytes(), cudaMemcpyHostToDevice));
  if (moments)
    NV_CUDA(cudaMemcpy(dMoments.get(), moments, dMoments.bytes(), cudaMemcpyHostToDevice));
  GpuDenoiser denoiser;
  denoiser.denoise(params, dNoisy.get(), dGuide.get(), moments ? dMoments.get() : nullptr, dOut.get(), nullptr);
  NV_CUDA(cudaDeviceSynchronize());
  NV_CUDA(cudaMemcpy(out, dOut.get(), dOut.bytes(), cudaMemcpyDeviceToHost));
}

double benchSessionInfer(NetworkSession& session, int64_t n, int reps)
{
  DeviceBuffer<float> dx(3 * n, "points"), dy(n, "outputs");
  randomPointsKernel<<<gridFor(n), 256>>>(dx.get(), n);
  NV_CUDA_LAUNCH();
  NV_CUDA(cudaDeviceSynchronize());
  return medianWallMs(reps, [&] { session.inferPoints(dx.get(), n, dy.get(), Memory::Device); });
}

double benchSessionDecode(NetworkSession& session, int64_t nx, int64_t ny, int64_t nz, int reps)
{
  DeviceBuffer<float> dy(nx * ny * nz, "decoded grid");
  return medianWallMs(reps, [&] { session.decodeGrid(nx, ny, nz, 0, nz, dy.get(), Memory::Device); });
}

float testLossAndGradient(const Model& model, const TrainConfig& config, const float* xyz, const float* targets,
  const uint8_t* valid, int64_t n, std::vector<float>& grad, const KernelOptions& kernels)
{
  const float unused[8] = { 0, 0, 0, 0, 0, 0, 0, 0 };
  VolumeView v;
  v.data = unused;
  v.dims[0] = v.dims[1] = v.dims[2] = 2;
  TrainConfig c = config;
  c.batchSize = static_cast<int>(std::max<int64_t>(n, 1));
  c.strategy = TrainingStrategy::GpuResident;
  c.importanceGrid = 0;
  const std::unique_ptr<Trainer> t = createTrainer(model, v, c, kernels, nullptr);
  return t->lossAndGradient(xyz, targets, valid, n, grad);
}

int inferenceBinning(int64_t n, int forced)
{
  return inferenceBinBits(n, forced);
}

bool forwardWeightsShared(const Model& model, const KernelOptions& options, int* bytes)
{
  Stream st;
  DeviceModel dm;
  uploadModel(model, dm, st.get());
  dm.options = options;
  const ForwardPlan& p = forwardPlan(dm, false);
  if (bytes)
    *bytes = p.bytes;
  return p.shared;
}

} // namespace gpu
} // namespace nv
