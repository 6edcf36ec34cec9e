// NeuralVolume engine: Sample Streaming's wavefront loop on the GPU, driven by the device. A batch of live rays
// emits the queries of its next K steps, the network infers them as one batch, the rays consume the values; batch
// after batch until no ray is live. The host never learns a batch's size: every kernel reads the loop's state from
// device memory (GpuStreamingKernels.cuh), and the loop itself is a CUDA graph whose WHILE node repeats the batch
// while rays are live (CUDA 12.4 or newer; the graph is built once per traced picture, i.e. per camera). So a frame
// enqueues its work and returns without waiting for the GPU. Built with an older CUDA, or where the graph cannot be
// made or launched (a warning, nv::postWarning), the host drives the same batches and reads the condition back after
// each (RenderStats::wavefrontHostSyncs counts those waits).
#pragma once

#include "Core/Render.h"
#include "GpuInternal.cuh"
#include "GpuRenderCommon.cuh"

#include <cstdint>
#include <string>

namespace nv
{
namespace gpu
{

class StreamingLoop
{
public:
  /// `network`: the session's device model (kept by reference).
  explicit StreamingLoop(const DeviceModel& network);
  ~StreamingLoop();
  StreamingLoop(const StreamingLoop&) = delete;
  StreamingLoop& operator=(const StreamingLoop&) = delete;

  /// One path (`sample`) of every pixel of P's image into image (ray marching) or accum (path tracing), counters
  /// in `counters` (device; RenderCounters::loop is reset here). `newPicture`: P, the image or the buffers may have
  /// changed since the last call (the first sample of a picture): the graph is rebuilt. Enqueued on `stream`; the
  /// host waits for nothing (unless the host-driven fallback runs: st.wavefrontHostSyncs).
  void trace(const ray::Params& P, int K, uint32_t sample, float4* image, float4* accum, RenderCounters* counters,
    cudaStream_t stream, bool newPicture, RenderStats& st);
  int64_t deviceMemoryBytes() const;

private:
  /// What one batch's launches read besides the buffers.
  struct Batch
  {
    ray::Params params;
    int K = 0, stride = 0;
    uint32_t rays = 0;     ///< rays per batch
    int64_t capacity = 0;  ///< query slots of a batch: rays * stride
    float4* image = nullptr;
    float4* accum = nullptr;
    RenderCounters* counters = nullptr;
  };
  void reserve(int64_t pixels, const Batch& b);
  /// The launches of one batch on `stream` (captured into the graph's loop body, or run by the host loop).
  void enqueueBatch(const Batch& b, cudaStream_t stream, unsigned long long handle, bool setCondition);
  /// The graph: a WHILE node around one batch; false (and GraphError set) where it cannot be made.
  bool buildGraph(const Batch& b);
  void releaseGraph();
  /// The fallback: the host enqueues batch after batch and reads the condition back after each.
  void runOnHost(const Batch& b, cudaStream_t stream, RenderStats& st);
  /// From now on the host drives the loop (a warning says why: GraphError).
  void fallBack();

  const DeviceModel& Network;
  DeviceBuffer<ray::Ray> Rays;
  DeviceBuffer<uint32_t> Active[2], Counts, Offsets;
  DeviceBuffer<float> Slots, Points, Values;
  PinnedBuffer<uint32_t> HostMore;
  cudaStream_t CaptureStream = nullptr; ///< graph capture only (never runs work)
  cudaGraph_t Graph = nullptr;
  cudaGraphExec_t Exec = nullptr;
  bool GraphFailed = false;             ///< the graph could not be made once: the host drives the loop from then on
  std::string GraphError;
};

} // namespace gpu
} // namespace nv
