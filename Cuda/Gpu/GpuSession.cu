// NeuralVolume engine: the CUDA backend of NetworkSession. Owns the network's device copy (fp16 table and weights,
// fp32 output row, and the fp32 parameters last published), one stream, the inference scratch and the host staging
// buffers, all created once; trainers publish into it on the device.
#include "Core/Backends.h"
#include "Core/Error.h"
#include "Cpu/ThreadPool.h"
#include "GpuEngine.h"
#include "GpuInternal.cuh"
#include "GpuRenderer.cuh"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <thread>

namespace nv
{

bool cudaBackendUsable(std::string* why, int cudaDevice)
{
  return gpu::deviceUsable(why, cudaDevice);
}

int cudaBackendDeviceCount()
{
  return gpu::deviceCount();
}

bool cudaDeviceMemory(int64_t& freeBytes, int64_t& totalBytes, int cudaDevice)
{
  freeBytes = totalBytes = 0;
  size_t f = 0, t = 0;
  if (cudaDevice >= 0 && (!gpu::deviceUsable(nullptr, cudaDevice) || cudaSetDevice(cudaDevice) != cudaSuccess))
  {
    cudaGetLastError();
    return false;
  }
  if (cudaMemGetInfo(&f, &t) != cudaSuccess)
  {
    cudaGetLastError(); // not sticky: clear it for the next CUDA call
    return false;
  }
  freeBytes = static_cast<int64_t>(f);
  totalBytes = static_cast<int64_t>(t);
  return true;
}

namespace gpu
{
namespace
{

/// Chunks of host-array inference and decoding: 3 slots, so the GPU fills chunk k while chunk k-1 is copied to
/// pinned memory (own copy stream) and host threads move chunk k-2 out of it.
constexpr int kSlots = 3;
constexpr int64_t kChunk = int64_t(1) << 22;

class GpuSession final : public NetworkSession
{
public:
  /// Made on the calling thread's current device (createCudaSession selects options.cudaDevice first); every call
  /// selects that device again on the thread it runs on.
  GpuSession(const Model& model, const SessionOptions& options)
    : Options(options)
    , Ordinal(currentDevice())
    , HostModel(model)
    , Corrections(sharedCorrections(model))
    , Pool(std::min(16, options.threads > 0 ? options.threads : ThreadPool::defaultThreads()))
  {
    upload(model);
    Renderer.reset(new GpuRenderer(Network, ComputeStream.get()));
  }

  ~GpuSession() override
  {
    cudaSetDevice(Ordinal); // the members are released on their device (nothing may leave a destructor)
    cudaStreamSynchronize(ComputeStream.get());
    cudaStreamSynchronize(CopyStream.get());
  }

  Device device() const override { return Device::Cuda; }
  int cudaDevice() const override { return Ordinal; }
  const Model& model() const override { return HostModel; }

  uint64_t version() const override
  {
    std::lock_guard<std::mutex> lock(Mutex);
    return Version;
  }

  void setModel(const Model& model) override
  {
    validate(model.config());
    NV_CHECK(model.paramCount() > 0, "model has no parameters");
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    HostModel = model;
    upload(model);
    Corrections = sharedCorrections(model);
    HostStale = false;
    ++Version;
  }

  std::shared_ptr<const ErrorCorrections> errorCorrections() const override
  {
    std::lock_guard<std::mutex> lock(Mutex);
    return Corrections;
  }

  void syncModel() override
  {
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    syncLocked();
  }

  Model currentModel() override
  {
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    syncLocked();
    return HostModel;
  }

  std::unique_ptr<Trainer> createTrainer(const VolumeView& volume, const TrainConfig& config) override
  {
    const TrainConfig c = trainerConfig(volume, config, Options);
    useDevice(Ordinal); // the trainer lives on the session's device
    std::lock_guard<std::mutex> lock(Mutex);
    syncLocked(); // the trainer starts from the current parameters
    // The trainer must not outlive the session (NetworkSession::createTrainer).
    return gpu::createTrainer(HostModel, volume, c, Options.kernels,
      [this](const float* dParams, void* stream) { publish(dParams, static_cast<cudaStream_t>(stream)); });
  }

  std::unique_ptr<Trainer> createTrainer(const TrainingPoints& points, const TrainConfig& config) override
  {
    const TrainConfig c = trainerConfig(points, config, Options);
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    syncLocked();
    return gpu::createTrainer(HostModel, points, c, Options.kernels,
      [this](const float* dParams, void* stream) { publish(dParams, static_cast<cudaStream_t>(stream)); });
  }

  std::unique_ptr<Trainer> createTrainer(BatchSource& source, const TrainConfig& config) override
  {
    const TrainConfig c = trainerConfig(source, config, Options);
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    syncLocked();
    return gpu::createTrainer(HostModel, source, c, Options.kernels,
      [this](const float* dParams, void* stream) { publish(dParams, static_cast<cudaStream_t>(stream)); });
  }

  void inferPoints(const float* xyz, int64_t n, float* out, Memory where) override
  {
    NV_CHECK(n >= 0 && (n == 0 || (xyz && out)), "inferPoints: invalid arguments");
    if (n == 0)
      return;
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    if (where == Memory::Device)
    {
      launchInference(Network, xyz, 0, 0, 0, 0, 0, n, out, ComputeStream.get());
      ComputeStream.sync();
      return;
    }
    pipeline(n, xyz, out, [&](int64_t b, int64_t m, const float* dIn, float* dOut) {
      launchInference(Network, dIn, 0, 0, 0, 0, 0, m, dOut, ComputeStream.get());
      (void)b;
    });
  }

  void decodeGrid(int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out, Memory where) override
  {
    NV_CHECK(nx >= 1 && ny >= 1 && nz >= 1, "decodeGrid: grid dimensions must be >= 1");
    NV_CHECK(z0 >= 0 && z0 <= z1 && z1 <= nz, "decodeGrid: invalid slice range");
    NV_CHECK(out != nullptr || z0 == z1, "decodeGrid: null output");
    NV_CHECK(nx <= (int64_t(1) << 20) && ny <= (int64_t(1) << 20) && nz <= (int64_t(1) << 20),
      "decodeGrid: more than 2^20 samples along an axis");
    if (z0 == z1)
      return;
    const int64_t n = nx * ny * (z1 - z0);
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    if (where == Memory::Device)
    {
      launchInference(Network, nullptr, nx, ny, nz, z0, 0, n, out, ComputeStream.get());
      ComputeStream.sync();
      return;
    }
    pipeline(n, nullptr, out, [&](int64_t b, int64_t m, const float*, float* dOut) {
      launchInference(Network, nullptr, nx, ny, nz, z0, b, m, dOut, ComputeStream.get());
    });
  }

  void render(const RenderRequest& request, RenderResult& result, Memory where) override
  {
    while (PublishWaiting.load() > 0) // a trained network is ready: let it in first
      std::this_thread::yield();
    useDevice(Ordinal);
    std::lock_guard<std::mutex> lock(Mutex);
    Renderer->render(HostModel, Version, request, result, where);
  }

  bool workPending() const override { return false; }

  int64_t deviceMemoryBytes() const override
  {
    std::lock_guard<std::mutex> lock(Mutex);
    size_t b = Network.bytes() + Network.encScratch.bytes() + Params32.bytes() + BackNetwork.bytes() +
      BackNetworkParams.bytes();
    for (int k = 0; k < kSlots; ++k)
      b += DeviceIn[k].bytes() + DeviceOut[k].bytes();
    return static_cast<int64_t>(b) + Renderer->deviceMemoryBytes();
  }

private:
  void upload(const Model& model)
  {
    ComputeStream.sync();
    Network.options = Options.kernels;
    allocateDeviceModel(model, Network);
    Params32.allocate(model.paramCount(), "parameters");
    NV_CUDA(cudaMemcpyAsync(Params32.get(), model.params().data(), Params32.bytes(), cudaMemcpyHostToDevice,
      ComputeStream.get()));
    packParams(Params32.get(), Network, ComputeStream.get());
    ComputeStream.sync();
  }

  /// Trainer::publish: the trainer's fp32 parameters become this session's. They are packed into the back copy of
  /// the network on the trainer's stream while renders go on, then swapped in between two renders; a waiting publish
  /// goes before the next render (render() yields to it), so training that publishes often is not starved by a
  /// render loop and never waits for more than the frame in flight.
  void publish(const float* dParams, cudaStream_t stream)
  {
    useDevice(Ordinal); // the trainer's thread
    std::lock_guard<std::mutex> one(PublishMutex); // one publish at a time
    {
      std::lock_guard<std::mutex> lock(Mutex);
      if (BackNetwork.table16.size() != Network.table16.size() || BackNetwork.w16.size() != Network.w16.size() ||
        BackNetworkParams.size() != Params32.size())
      {
        BackNetwork.options = Network.options;
        allocateDeviceModel(HostModel, BackNetwork);
        BackNetworkParams.allocate(Params32.size(), "parameters (back copy)");
      }
      // The back copy was the network of earlier renders, which may still run on the GPU (a deferred render,
      // RenderRequest::deferDeviceSync): the packing below waits for the last one.
      NV_CUDA(cudaStreamWaitEvent(stream, Renderer->lastRenderEnd(), 0));
    }
    NV_CUDA(cudaMemcpyAsync(BackNetworkParams.get(), dParams, BackNetworkParams.bytes(), cudaMemcpyDeviceToDevice,
      stream));
    packParams(BackNetworkParams.get(), BackNetwork, stream);
    NV_CUDA(cudaStreamSynchronize(stream));
    ++PublishWaiting;
    {
      std::lock_guard<std::mutex> lock(Mutex);
      std::swap(Network.table16, BackNetwork.table16);
      std::swap(Network.w16, BackNetwork.w16);
      std::swap(Network.wout, BackNetwork.wout);
      std::swap(Params32, BackNetworkParams);
      HostModel.corrections = ErrorCorrections(); // computed for the parameters replaced
      Corrections.reset();
      HostStale = true;
      ++Version;
    }
    --PublishWaiting;
  }

  void syncLocked()
  {
    if (!HostStale)
      return;
    NV_CUDA(cudaMemcpyAsync(HostModel.params().data(), Params32.get(), Params32.bytes(), cudaMemcpyDeviceToHost,
      ComputeStream.get()));
    ComputeStream.sync();
    HostStale = false;
  }

  /// Host-array inference in chunks: launch(b, m, dIn, dOut) computes chunk [b, b + m) into dOut (dIn holds the
  /// chunk's points when `in` is not null).
  template <typename Launch>
  void pipeline(int64_t n, const float* in, float* out, Launch&& launch)
  {
    const int64_t chunk = std::min(n, kChunk);
    for (int k = 0; k < kSlots; ++k)
    {
      if (DeviceOut[k].size() < size_t(chunk))
      {
        DeviceOut[k].allocate(size_t(chunk), "inference outputs");
        HostOut[k].allocate(size_t(chunk));
      }
      if (in && DeviceIn[k].size() < size_t(3 * chunk))
      {
        DeviceIn[k].allocate(size_t(3 * chunk), "inference points");
        HostIn[k].allocate(size_t(3 * chunk));
      }
    }
    const int64_t chunks = (n + chunk - 1) / chunk;
    auto parallelCopy = [&](float* dst, const float* src, int64_t count) {
      Pool.parallelFor(count, [&](int64_t s, int64_t e, int) { std::memcpy(dst + s, src + s, (e - s) * sizeof(float)); });
    };
    auto drain = [&](int64_t k) {
      const int slot = static_cast<int>(k % kSlots);
      NV_CUDA(cudaEventSynchronize(Done[slot].get()));
      const int64_t b = k * chunk, m = std::min(chunk, n - b);
      parallelCopy(out + b, HostOut[slot].get(), m);
    };
    for (int64_t k = 0; k < chunks; ++k)
    {
      const int slot = static_cast<int>(k % kSlots); // chunk k - kSlots was drained in iteration k - 1
      const int64_t b = k * chunk, m = std::min(chunk, n - b);
      if (in)
      {
        parallelCopy(HostIn[slot].get(), in + 3 * b, 3 * m);
        NV_CUDA(cudaMemcpyAsync(DeviceIn[slot].get(), HostIn[slot].get(), 3 * m * sizeof(float), cudaMemcpyHostToDevice,
          ComputeStream.get()));
      }
      launch(b, m, in ? DeviceIn[slot].get() : nullptr, DeviceOut[slot].get());
      NV_CUDA(cudaEventRecord(Filled[slot].get(), ComputeStream.get()));
      NV_CUDA(cudaStreamWaitEvent(CopyStream.get(), Filled[slot].get(), 0));
      NV_CUDA(cudaMemcpyAsync(HostOut[slot].get(), DeviceOut[slot].get(), m * sizeof(float), cudaMemcpyDeviceToHost,
        CopyStream.get()));
      NV_CUDA(cudaEventRecord(Done[slot].get(), CopyStream.get()));
      if (k >= kSlots - 1)
        drain(k - (kSlots - 1));
    }
    for (int64_t k = std::max<int64_t>(0, chunks - (kSlots - 1)); k < chunks; ++k)
      drain(k);
  }

  SessionOptions Options;
  int Ordinal = 0; ///< the CUDA device of every resource of this session
  mutable std::mutex Mutex;
  Model HostModel;
  std::shared_ptr<const ErrorCorrections> Corrections; ///< of HostModel's parameters; null once a trainer publishes
  bool HostStale = false;
  uint64_t Version = 1;
  Stream ComputeStream{ StreamPriority::Highest }; ///< renders and inference: a view waits for them
  Stream CopyStream{ StreamPriority::Highest };
  DeviceModel Network;
  DeviceBuffer<float> Params32;
  DeviceModel BackNetwork;               ///< publish(): the next network, packed while renders use Network
  DeviceBuffer<float> BackNetworkParams;
  std::mutex PublishMutex;
  std::atomic<int> PublishWaiting{ 0 };
  DeviceBuffer<float> DeviceIn[kSlots], DeviceOut[kSlots];
  PinnedBuffer<float> HostIn[kSlots], HostOut[kSlots];
  Event Filled[kSlots], Done[kSlots];
  ThreadPool Pool;
  std::unique_ptr<GpuRenderer> Renderer;
};

} // namespace
} // namespace gpu

std::unique_ptr<NetworkSession> createCudaSession(const Model& model, const SessionOptions& options)
{
  std::string why;
  NV_CHECK(options.cudaDevice >= -1, "SessionOptions::cudaDevice must be -1 (the current device) or an ordinal");
  NV_CHECK(gpu::deviceUsable(&why, options.cudaDevice), "CUDA device requested but not usable: " + why);
  if (options.cudaDevice >= 0)
    gpu::useDevice(options.cudaDevice); // the session's resources are made there
  return std::unique_ptr<NetworkSession>(new gpu::GpuSession(model, options));
}

} // namespace nv
