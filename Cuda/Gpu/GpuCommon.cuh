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

template <typename T>
class DeviceBuffer
{
public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(size_t n, const char* what = "buffer") { allocate(n, what); }
  ~DeviceBuffer() { release(); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept
    : Ptr(o.Ptr)
    , Count(o.Count)
  {
    o.Ptr = nullptr;
    o.Count = 0;
  }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept
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
    if (n > 0)
    {
      Ptr = static_cast<T*>(deviceAlloc(n * sizeof(T), what));
      Count = n;
    }
  }
  void release()
  {
    if (Ptr)
    {
      cudaFree(Ptr); // never throws from a destructor
      Ptr = nullptr;
      Count = 0;
    }
  }
  T* get() const { return Ptr; }
  size_t size() const { return Count; }
  size_t bytes() const { return Count * sizeof(T); }

private:
  T* Ptr = nullptr;
  size_t Count = 0;
};

/// Page-locked host memory (for asynchronous copies).
template <typename T>
class PinnedBuffer
{
public:
  PinnedBuffer() = default;
  explicit PinnedBuffer(size_t n) { allocate(n); }
  ~PinnedBuffer() { release(); }
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  PinnedBuffer(PinnedBuffer&& o) noexcept
    : Ptr(o.Ptr)
    , Count(o.Count)
  {
    o.Ptr = nullptr;
    o.Count = 0;
  }
  PinnedBuffer& operator=(PinnedBuffer&& o) noexcept
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
  void allocate(size_t n)
  {
    release();
    if (n > 0)
    {
      void* p = nullptr;
      NV_CUDA(cudaMallocHost(&p, n * sizeof(T)));
      Ptr = static_cast<T*>(p);
      Count = n;
    }
  }
  void release()
  {
    if (Ptr)
    {
      cudaFreeHost(Ptr);
      Ptr = nullptr;
      Count = 0;
    }
  }
  T* get() const { return Ptr; }
  size_t size() const { return Count; }

private:
  T* Ptr = nullptr;
  size_t Count = 0;
};

class Stream
{
public:
  Stream() { NV_CUDA(cudaStreamCreateWithFlags(&S, cudaStreamNonBlocking)); }
  ~Stream()
  {
    if (S)
      cudaStreamDestroy(S);
  }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  Stream(Stream&& o) noexcept
    : S(o.S)
  {
    o.S = nullptr;
  }
  cudaStream_t get() const { return S; }
  void sync() const { NV_CUDA(cudaStreamSynchronize(S)); }

private:
  cudaStream_t S = nullptr;
};

class Event
{
public:
  Event() { NV_CUDA(cudaEventCreate(&E)); }
  ~Event()
  {
    if (E)
      cudaEventDestroy(E);
  }
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  Event(Event&& o) noexcept
    : E(o.E)
  {
    o.E = nullptr;
  }
  cudaEvent_t get() const { return E; }

private:
  cudaEvent_t E = nullptr;
};

} // namespace gpu
} // namespace nv
