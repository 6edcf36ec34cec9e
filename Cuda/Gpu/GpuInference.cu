// NeuralVolume engine: CUDA device queries, parameter packing, the inference entry point (the forward kernel of
// GpuForward.cu) and test/benchmark hooks.
#include "Core/Model.h"
#include "GpuEngine.h"
#include "GpuInternal.cuh"
#include "GpuTesting.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <mutex>
#include <sstream>
#include <vector>

namespace nv
{
namespace gpu
{

void throwCuda(cudaError_t e, const char* call, const char* file, int line)
{
  std::ostringstream os;
  os << "CUDA error " << cudaGetErrorName(e) << " (" << cudaGetErrorString(e) << ") in " << call;
  cudaGetLastError(); // clear a non-sticky error
  throwError(file, line, os.str());
}

void* deviceAlloc(size_t bytes, const char* what)
{
  void* p = nullptr;
  const cudaError_t e = cudaMalloc(&p, bytes);
  if (e == cudaErrorMemoryAllocation)
  {
    cudaGetLastError();
    size_t freeB = 0, totalB = 0;
    cudaMemGetInfo(&freeB, &totalB);
    std::ostringstream os;
    os << "out of GPU memory: cannot allocate " << bytes / 1048576.0 << " MiB for " << what << " ("
       << freeB / 1048576.0 << " MiB free of " << totalB / 1048576.0 << " MiB)";
    NV_THROW(os.str());
  }
  NV_CUDA(e);
  return p;
}

namespace
{
__global__ void probeKernel(int* p)
{
  if (p)
    *p = 1;
}

struct Usable
{
  bool ok = false;
  std::string why;
};

const Usable& usable()
{
  static Usable u;
  static std::once_flag once;
  std::call_once(once, [] {
    int count = 0;
    cudaError_t e = cudaGetDeviceCount(&count);
    if (e != cudaSuccess)
    {
      // No driver or no device is the ordinary machine without a GPU: a plain reason, not a CUDA error text.
      if (e == cudaErrorNoDevice)
        u.why = "no NVIDIA GPU found";
      else if (e == cudaErrorInsufficientDriver)
        u.why = "no NVIDIA GPU with a driver for CUDA " + std::to_string(CUDART_VERSION / 1000) + " found";
      else
        u.why = std::string("CUDA runtime reports ") + cudaGetErrorString(e);
      cudaGetLastError();
      return;
    }
    if (count == 0)
    {
      u.why = "no NVIDIA GPU found";
      return;
    }
    cudaDeviceProp p;
    if (cudaGetDeviceProperties(&p, 0) != cudaSuccess)
    {
      cudaGetLastError();
      u.why = "cannot query CUDA device 0";
      return;
    }
    if (p.major != 9)
    {
      std::ostringstream os;
      os << "GPU '" << p.name << "' has compute capability " << p.major << "." << p.minor
         << "; this build of NeuralVolume supports compute capability 9.x (sm_90, Hopper) only";
      u.why = os.str();
      return;
    }
    cudaFuncAttributes fa;
    e = cudaFuncGetAttributes(&fa, probeKernel);
    if (e != cudaSuccess)
    {
      u.why = std::string("the CUDA kernels cannot run on '") + p.name + "': " + cudaGetErrorString(e);
      cudaGetLastError();
      return;
    }
    u.ok = true;
  });
  return u;
}

__global__ void toHalfKernel(const float* __restrict__ src, __half* __restrict__ dst, int64_t n)
{
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
    dst[i] = __float2half_rn(src[i]);
}

__global__ void packMlpKernel(const float* __restrict__ mlp, MlpShape s, __half* __restrict__ w16, float* __restrict__ wout,
  int64_t count)
{
  for (int64_t j = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; j < count; j += int64_t(gridDim.x) * blockDim.x)
  {
    const MlpSlot m = mlpSlot(s, j);
    if (m.layer == s.H)
      wout[m.column] = mlp[j];
    else
      w16[m.padded] = __float2half_rn(mlp[j]);
  }
}

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

int gridFor(int64_t n, int threads)
{
  const int64_t b = (n + threads - 1) / threads;
  return static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(b, int64_t(deviceInfo().sms) * 32)));
}

const DeviceInfo& deviceInfo()
{
  static DeviceInfo info;
  static std::once_flag once;
  std::call_once(once, [] {
    NV_CUDA(cudaGetDevice(&info.device));
    cudaDeviceProp p;
    NV_CUDA(cudaGetDeviceProperties(&p, info.device));
    info.sms = p.multiProcessorCount;
    info.maxSmemOptin = static_cast<int>(p.sharedMemPerBlockOptin);
    info.totalMem = p.totalGlobalMem;
    info.name = p.name;
    info.major = p.major;
    info.minor = p.minor;
  });
  return info;
}

bool deviceUsable(std::string* why)
{
  const Usable& u = usable();
  if (!u.ok && why)
    *why = u.why;
  return u.ok;
}

std::string deviceDescription()
{
  const DeviceInfo& d = deviceInfo();
  std::ostringstream os;
  os << d.name << " (sm_" << d.major << d.minor << ", " << d.sms << " SMs, " << d.totalMem / 1048576 << " MiB)";
  return os.str();
}

SmemPlan choosePlan(const MlpShape& s, bool training, const void* fn, int* blocksPerSm)
{
  // First plan that fits: weights in shared memory and the largest tile (8 warps). Measured on an H100 (see
  // Testing/Benchmarks/results/gpu_notes.md): choosing the plan with the most resident warps instead (smaller
  // tiles, weights through L1) was slower for training (0.94 vs 0.82 ms), inference and decode.
  const int limit = deviceInfo().maxSmemOptin;
  NV_CUDA(cudaFuncSetAttribute(fn, cudaFuncAttributeMaxDynamicSharedMemorySize, limit));
  SmemPlan best{};
  int bestWarps = 0, bestBlocks = 0;
  for (int w : { 1, 0 })
    for (int warps : { 8, 4, 2, 1 })
    {
      const SmemPlan p = makeSmemPlan(s, warps, training, w == 1);
      if (bestWarps > 0 || p.total > limit)
        continue;
      int perSm = 0;
      NV_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&perSm, fn, warps * 32, p.total));
      if (perSm > 0)
      {
        best = p;
        bestWarps = perSm * warps;
        bestBlocks = perSm;
      }
    }
  NV_CHECK(bestWarps > 0, "network too large for the GPU's shared memory");
  if (blocksPerSm)
    *blocksPerSm = bestBlocks;
  return best;
}

void allocateDeviceModel(const Model& model, DeviceModel& dm)
{
  dm.fwdPlan[0] = dm.fwdPlan[1] = ForwardPlan();
  dm.grid = model.layout();
  dm.shape = makeMlpShape(model.config());
  dm.table16.allocate(model.encodingParamCount(), "fp16 hash table");
  dm.w16.allocate(dm.shape.total, "fp16 MLP weights");
  dm.wout.allocate(dm.shape.W, "output layer");
}

void packParams(const float* dParams, DeviceModel& dm, cudaStream_t stream)
{
  const int64_t ne = static_cast<int64_t>(dm.table16.size());
  toHalfKernel<<<gridFor(ne), 256, 0, stream>>>(dParams, dm.table16.get(), ne);
  NV_CUDA_LAUNCH();
  NV_CUDA(cudaMemsetAsync(dm.w16.get(), 0, dm.w16.bytes(), stream));
  const MlpShape& s = dm.shape;
  const int64_t nm = int64_t(s.W) * s.D + int64_t(s.H - 1) * s.W * s.W + s.W;
  packMlpKernel<<<gridFor(nm), 256, 0, stream>>>(dParams + ne, s, dm.w16.get(), dm.wout.get(), nm);
  NV_CUDA_LAUNCH();
}

void uploadModel(const Model& model, DeviceModel& dm, cudaStream_t stream)
{
  allocateDeviceModel(model, dm);
  DeviceBuffer<float> p(model.paramCount(), "parameters");
  NV_CUDA(cudaMemcpyAsync(p.get(), model.params().data(), p.bytes(), cudaMemcpyHostToDevice, stream));
  packParams(p.get(), dm, stream);
  NV_CUDA(cudaStreamSynchronize(stream)); // p is freed on return
}

void launchInference(const DeviceModel& dm, const float* xyz, int64_t nx, int64_t ny, int64_t nz, int64_t z0,
  int64_t first, int64_t n, float* out, cudaStream_t stream)
{
  if (n <= 0)
    return;
  launchForward(dm, xyz, nx, ny, nz, z0, first, n, out, stream);
}

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

double benchInferKernel(const Model& model, int64_t n, int reps)
{
  Stream st;
  DeviceModel dm;
  uploadModel(model, dm, st.get());
  DeviceBuffer<float> dx(3 * n), dy(n);
  randomPointsKernel<<<gridFor(n), 256, 0, st.get()>>>(dx.get(), n);
  NV_CUDA_LAUNCH();
  return medianMs(reps, st.get(), [&] { launchInference(dm, dx.get(), 0, 0, 0, 0, 0, n, dy.get(), st.get()); });
}

double benchDecodeKernel(const Model& model, int64_t nx, int64_t ny, int64_t nz, int reps)
{
  Stream st;
  DeviceModel dm;
  uploadModel(model, dm, st.get());
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

void copyToHost(const float* device, size_t n, float* host)
{
  NV_CUDA(cudaMemcpy(host, device, n * sizeof(float), cudaMemcpyDeviceToHost));
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

} // namespace gpu
} // namespace nv
