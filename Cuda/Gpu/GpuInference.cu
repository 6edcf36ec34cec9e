// NeuralVolume engine: CUDA device queries, parameter packing and the inference entry point (the forward kernel of
// GpuForward.cu).
#include "Core/Model.h"
#include "GpuEngine.h"
#include "GpuInternal.cuh"

#include <algorithm>
#include <cstring>
#include <mutex>
#include <sstream>
#include <vector>

#ifndef NV_CUDA_ARCHITECTURES
#define NV_CUDA_ARCHITECTURES "an unknown list of architectures"
#endif

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

/// Devices whose properties and usability are cached (ordinals 0..kMaxDevices-1).
constexpr int kMaxDevices = 64;

/// The runtime's device count, or why there is none (queried once).
const Usable& runtimeUsable(int* devices)
{
  static Usable u;
  static int count = 0;
  static std::once_flag once;
  std::call_once(once, [] {
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
      count = 0;
      return;
    }
    if (count == 0)
    {
      u.why = "no NVIDIA GPU found";
      return;
    }
    u.ok = true;
  });
  *devices = count;
  return u;
}

/// Whether this build's kernels run on device `ordinal` (queried once per device). The kernel query runs on the
/// current device: device `ordinal` becomes the calling thread's current device and stays so (switching back would
/// make a context on the previous device -- since CUDA 12 cudaSetDevice creates it -- in a process that never uses
/// it: an MPI rank on device 1 would hold memory on device 0 too).
Usable checkDevice(int ordinal)
{
  Usable u;
  cudaDeviceProp p;
  if (cudaGetDeviceProperties(&p, ordinal) != cudaSuccess)
  {
    cudaGetLastError();
    u.why = "cannot query CUDA device " + std::to_string(ordinal);
    return u;
  }
  if (p.major * 10 + p.minor < 75)
  {
    std::ostringstream os;
    os << "GPU '" << p.name << "' has compute capability " << p.major << "." << p.minor
       << "; NeuralVolume's CUDA engine needs 7.5 (Turing) or newer";
    u.why = os.str();
    return u;
  }
  int current = 0;
  const bool switching = cudaGetDevice(&current) == cudaSuccess && current != ordinal;
  if (switching && cudaSetDevice(ordinal) != cudaSuccess)
  {
    cudaGetLastError();
    u.why = "cannot select CUDA device " + std::to_string(ordinal);
    return u;
  }
  cudaFuncAttributes fa;
  const cudaError_t e = cudaFuncGetAttributes(&fa, probeKernel);
  if (e != cudaSuccess)
  {
    std::ostringstream os;
    os << "the CUDA kernels cannot run on '" << p.name << "' (sm_" << p.major << p.minor << "): ";
    if (e == cudaErrorNoKernelImageForDevice || e == cudaErrorInvalidKernelImage)
      os << "this build has no code for it (built for " << NV_CUDA_ARCHITECTURES
         << "; rebuild with CMAKE_CUDA_ARCHITECTURES including " << p.major << p.minor << ")";
    else if (e == cudaErrorUnsupportedPtxVersion)
      os << "its driver is older than this build's CUDA " << CUDART_VERSION / 1000 << "." << CUDART_VERSION % 1000 / 10
         << " (update the NVIDIA driver)";
    else
      os << cudaGetErrorString(e);
    u.why = os.str();
    cudaGetLastError();
    return u;
  }
  u.ok = true;
  return u;
}

const Usable& usable(int ordinal)
{
  static Usable devices[kMaxDevices];
  static std::once_flag once[kMaxDevices];
  std::call_once(once[ordinal], [ordinal] { devices[ordinal] = checkDevice(ordinal); });
  return devices[ordinal];
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
    if (m.layer == s.hiddenLayers)
      wout[m.column] = mlp[j];
    else
      w16[m.padded] = __float2half_rn(mlp[j]);
  }
}

} // namespace

int gridFor(int64_t n, int threads)
{
  const int64_t b = (n + threads - 1) / threads;
  return static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(b, int64_t(deviceInfo().sms) * 32)));
}

int currentDevice()
{
  int device = 0;
  NV_CUDA(cudaGetDevice(&device));
  return device;
}

void useDevice(int ordinal)
{
  if (currentDevice() != ordinal)
    NV_CUDA(cudaSetDevice(ordinal));
}

const DeviceInfo& deviceInfo()
{
  static DeviceInfo info[kMaxDevices];
  static std::once_flag once[kMaxDevices];
  const int device = currentDevice();
  NV_CHECK(device >= 0 && device < kMaxDevices, "CUDA device ordinal beyond " + std::to_string(kMaxDevices - 1));
  std::call_once(once[device], [device] {
    DeviceInfo& d = info[device];
    d.device = device;
    cudaDeviceProp p;
    NV_CUDA(cudaGetDeviceProperties(&p, device));
    d.sms = p.multiProcessorCount;
    d.maxSmemOptin = static_cast<int>(p.sharedMemPerBlockOptin);
    d.totalMem = p.totalGlobalMem;
    d.name = p.name;
    d.major = p.major;
    d.minor = p.minor;
  });
  return info[device];
}

int deviceCount()
{
  int devices = 0;
  runtimeUsable(&devices);
  return devices;
}

bool deviceUsable(std::string* why, int ordinal)
{
  int devices = 0;
  const Usable& runtime = runtimeUsable(&devices);
  std::string reason;
  bool ok = runtime.ok;
  if (!ok)
    reason = runtime.why;
  else
  {
    if (ordinal < 0 && cudaGetDevice(&ordinal) != cudaSuccess)
    {
      cudaGetLastError();
      ordinal = 0;
    }
    if (ordinal >= devices || ordinal >= kMaxDevices)
    {
      ok = false;
      reason = "no CUDA device " + std::to_string(ordinal) + " (this process sees " + std::to_string(devices) + ")";
    }
    else
    {
      const Usable& u = usable(ordinal);
      ok = u.ok;
      reason = u.why;
    }
  }
  if (!ok && why)
    *why = reason;
  return ok;
}

std::string deviceDescription()
{
  const DeviceInfo& d = deviceInfo();
  std::ostringstream os;
  os << d.name << " (sm_" << d.major << d.minor << ", " << d.sms << " SMs, " << d.totalMem / 1048576 << " MiB)";
  return os.str();
}

int sharedMemoryLimit(const KernelOptions& options)
{
  const int device = deviceInfo().maxSmemOptin;
  return options.sharedMemoryLimit > 0 ? std::min(device, options.sharedMemoryLimit) : device;
}

SmemPlan choosePlan(const MlpShape& s, bool training, const void* fn, int limit, int* blocksPerSm)
{
  // First plan that fits: weights in shared memory and the largest tile (8 warps). Measured on an H100 (see
  // Testing/Benchmarks/results/gpu_notes.md): choosing the plan with the most resident warps instead (smaller
  // tiles, weights through L1) was slower for training (0.94 vs 0.82 ms), inference and decode.
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
  dm.wout.allocate(dm.shape.width, "output layer");
}

void packParams(const float* dParams, DeviceModel& dm, cudaStream_t stream)
{
  const int64_t ne = static_cast<int64_t>(dm.table16.size());
  toHalfKernel<<<gridFor(ne), 256, 0, stream>>>(dParams, dm.table16.get(), ne);
  NV_CUDA_LAUNCH();
  NV_CUDA(cudaMemsetAsync(dm.w16.get(), 0, dm.w16.bytes(), stream));
  const MlpShape& s = dm.shape;
  const int64_t nm = int64_t(s.width) * s.inputs + int64_t(s.hiddenLayers - 1) * s.width * s.width + s.width;
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

} // namespace gpu
} // namespace nv
