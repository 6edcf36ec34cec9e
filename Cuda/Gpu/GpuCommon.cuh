// NeuralVolume engine: CUDA error checks and move-only RAII owners of device resources.
#pragma once

#include "Core/Error.h"

#include <cuda_fp16.h>
#include <cuda_runtime.h>

#include <cstddef>
#include <string>

namespace nv
{
namespace gpu
{

[[noreturn]] void throwCuda(cudaError_t e, const char* call, const char* file, int line);

} // namespace gpu
} // namespace nv

/// Every CUDA runtime call goes through this: throws nv::Error with file:line and the call text.
#define NV_CUDA(call)                                                                              \
  do                                                                                               \
  {                                                                                                \
    const cudaError_t nvErr_ = (call);                                                             \
    if (nvErr_ != cudaSuccess)                                                                     \
      ::nv::gpu::throwCuda(nvErr_, #call, __FILE__, __LINE__);                                     \
  } while (0)
/// After each kernel launch.
#define NV_CUDA_LAUNCH() NV_CUDA(cudaGetLastError())

namespace nv
{
namespace gpu
{

/// Allocates with a readable message when the GPU is out of memory.
void* deviceAlloc(size_t bytes, const char* what);

/// Move-only owner of n elements of T in device memory (Pinned = false) or page-locked host memory (Pinned = true,
/// for asynchronous copies).
template <typename T, bool Pinned>
class CudaBuffer
{
public:
  CudaBuffer() = default;
  explicit CudaBuffer(size_t n, const char* what = "buffer") { allocate(n, what); }
  ~CudaBuffer() { release(); }
  CudaBuffer(const CudaBuffer&) = delete;
  CudaBuffer& operator=(const CudaBuffer&) = delete;
  CudaBuffer(CudaBuffer&& o) noexcept
    : Ptr(o.Ptr)
    , Count(o.Count)
  {
    o.Ptr = nullptr;
    o.Count = 0;
  }
  CudaBuffer& operator=(CudaBuffer&& o) noexcept
  {
    if (this != &o)
    {
      release();
      Ptr = o.Ptr;
      Count = o.Count;
      o.Ptr = nullptr;
      o.Count = 0;
    }
    return *this;
  }
  void allocate(size_t n, const char* what = "buffer")
  {
    release();
    if (n == 0)
      return;
    if constexpr (Pinned)
    {
      void* p = nullptr;
      NV_CUDA(cudaMallocHost(&p, n * sizeof(T)));
      Ptr = static_cast<T*>(p);
    }
    else
    {
      Ptr = static_cast<T*>(deviceAlloc(n * sizeof(T), what));
    }
    Count = n;
  }
  void release()
  {
    if (!Ptr)
      return;
    if constexpr (Pinned) // never throws from a destructor
      cudaFreeHost(Ptr);
    else
      cudaFree(Ptr);
    Ptr = nullptr;
    Count = 0;
  }
  T* get() const { return Ptr; }
  size_t size() const { return Count; }
  size_t bytes() const { return Count * sizeof(T); }

private:
  T* Ptr = nullptr;
  size_t Count = 0;
};

template <typename T>
using DeviceBuffer = CudaBuffer<T, false>;
template <typename T>
using PinnedBuffer = CudaBuffer<T, true>;

/// The scheduling priority of a stream's kernels: a GPU shared by a training run and the renders of a view it is
/// shown in gives the renders' blocks the SMs first as they free up (training's kernels are short, so a frame waits
/// for at most the blocks already running, not for the steps queued behind them).
enum class StreamPriority
{
  Normal,  ///< the device's lowest (the default): training, background work
  Highest, ///< the device's highest: work a view waits for (renders, the Decode path's grid)
};

class Stream
{
public:
  explicit Stream(StreamPriority priority = StreamPriority::Normal)
  {
    int lowest = 0, highest = 0;
    NV_CUDA(cudaDeviceGetStreamPriorityRange(&lowest, &highest));
    NV_CUDA(cudaStreamCreateWithPriority(
      &Handle, cudaStreamNonBlocking, priority == StreamPriority::Highest ? highest : lowest));
  }
  ~Stream()
  {
    if (Handle)
      cudaStreamDestroy(Handle);
  }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  Stream(Stream&& o) noexcept
    : Handle(o.Handle)
  {
    o.Handle = nullptr;
  }
  cudaStream_t get() const { return Handle; }
  void sync() const { NV_CUDA(cudaStreamSynchronize(Handle)); }

private:
  cudaStream_t Handle = nullptr;
};

class Event
{
public:
  Event() { NV_CUDA(cudaEventCreate(&Handle)); }
  ~Event()
  {
    if (Handle)
      cudaEventDestroy(Handle);
  }
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  Event(Event&& o) noexcept
    : Handle(o.Handle)
  {
    o.Handle = nullptr;
  }
  cudaEvent_t get() const { return Handle; }

private:
  cudaEvent_t Handle = nullptr;
};

} // namespace gpu
} // namespace nv
