// NeuralVolume engine: Sample Streaming's device-driven wavefront loop (see GpuStreamingLoop.cuh).
#include "GpuStreamingLoop.cuh"

#include "Core/EngineWarnings.h"
#include "Core/Error.h"
#include "GpuStreamingKernels.cuh"

#include <algorithm>

#if CUDART_VERSION >= 12040
#define NV_STREAMING_GRAPH 1
#else
#define NV_STREAMING_GRAPH 0
#endif

namespace nv
{
namespace gpu
{

namespace
{
/// Queries of one batch at most (points 12 B + value 4 B + slot 12 B each, and at most one inference chunk), unless
/// KernelOptions::streamBatchQueries.
constexpr int64_t kMaxStreamQueries = int64_t(1) << 23;
/// The loop's safety bound (a ray machine that never finished would loop forever): RenderCounters::truncated.
constexpr uint32_t kMaxBatches = uint32_t(ray::kMaxIterations);
} // namespace

StreamingLoop::StreamingLoop(const DeviceModel& network)
  : Network(network)
{
  HostMore.allocate(1);
}

StreamingLoop::~StreamingLoop()
{
  releaseGraph();
  if (CaptureStream)
    cudaStreamDestroy(CaptureStream);
}

int64_t StreamingLoop::deviceMemoryBytes() const
{
  return static_cast<int64_t>(Rays.bytes() + Active[0].bytes() + Active[1].bytes() + Counts.bytes() +
    Offsets.bytes() + Slots.bytes() + Points.bytes() + Values.bytes());
}

void StreamingLoop::releaseGraph()
{
  if (Exec)
    cudaGraphExecDestroy(Exec);
  if (Graph)
    cudaGraphDestroy(Graph);
  Exec = nullptr;
  Graph = nullptr;
}

void StreamingLoop::reserve(int64_t pixels, const Batch& b)
{
  // (Every buffer a captured launch reads exists before the capture: nothing is allocated inside the loop.)
  if (Rays.size() < size_t(pixels))
  {
    releaseGraph();
    Rays.allocate(size_t(pixels), "wavefront rays");
    Active[0].allocate(size_t(pixels), "live rays");
    Active[1].allocate(size_t(pixels), "live rays");
  }
  if (Counts.size() < size_t(b.rays))
  {
    releaseGraph();
    Counts.allocate(size_t(b.rays), "query counts");
    Offsets.allocate(size_t(b.rays), "query offsets");
  }
  if (Values.size() < size_t(b.capacity))
  {
    releaseGraph();
    Slots.allocate(3 * size_t(b.capacity), "wavefront query slots");
    Points.allocate(3 * size_t(b.capacity), "wavefront queries");
    Values.allocate(size_t(b.capacity), "wavefront values");
  }
  reserveInference(Network, b.capacity);
}

void StreamingLoop::enqueueBatch(const Batch& b, cudaStream_t stream, unsigned long long handle, bool setCondition)
{
  RenderCounters* c = b.counters;
  emitPackKernel<<<gridFor(b.rays), 256, 0, stream>>>(b.params, Rays.get(), Active[0].get(), Active[1].get(), c,
    b.rays, b.K, b.stride, Slots.get(), Counts.get(), Offsets.get(), Points.get());
  NV_CUDA_LAUNCH();
  // The batch's queries: as many as emitPackKernel counted into c->loop.points (read by the kernels).
  launchForward(Network, Points.get(), 0, 0, 0, 0, 0, b.capacity, Values.get(), stream, &c->loop.points);
  consumeKernel<<<gridFor(b.rays), 256, 0, stream>>>(b.params, Rays.get(), Active[0].get(), Active[1].get(), b.rays,
    b.K, Counts.get(), Offsets.get(), Points.get(), Values.get(), c, b.image, b.accum);
  NV_CUDA_LAUNCH();
  advanceKernel<<<1, 32, 0, stream>>>(c, b.rays, kMaxBatches, handle, setCondition ? 1 : 0);
  NV_CUDA_LAUNCH();
}

bool StreamingLoop::buildGraph(const Batch& b)
{
  releaseGraph();
#if NV_STREAMING_GRAPH
  if (!CaptureStream)
    NV_CUDA(cudaStreamCreateWithFlags(&CaptureStream, cudaStreamNonBlocking));
  bool capturing = false;
  try
  {
    NV_CUDA(cudaGraphCreate(&Graph, 0));
    // The condition is 1 at every launch (the body runs once even without a live ray: its kernels find an empty
    // batch) and then whatever advanceKernel sets.
    cudaGraphConditionalHandle handle = 0;
    NV_CUDA(cudaGraphConditionalHandleCreate(&handle, Graph, 1, cudaGraphCondAssignDefault));
    cudaGraphNodeParams node{};
    node.type = cudaGraphNodeTypeConditional;
    node.conditional.handle = handle;
    node.conditional.type = cudaGraphCondTypeWhile;
    node.conditional.size = 1;
    cudaGraphNode_t loop = nullptr;
    NV_CUDA(cudaGraphAddNode(&loop, Graph, nullptr, nullptr, 0, &node));
    cudaGraph_t body = node.conditional.phGraph_out[0];
    // Captured on a stream of its own (relaxed: other threads' CUDA calls meanwhile are no concern of the capture).
    NV_CUDA(cudaStreamBeginCaptureToGraph(CaptureStream, body, nullptr, nullptr, 0, cudaStreamCaptureModeRelaxed));
    capturing = true;
    enqueueBatch(b, CaptureStream, static_cast<unsigned long long>(handle), true);
    capturing = false;
    cudaGraph_t captured = nullptr;
    NV_CUDA(cudaStreamEndCapture(CaptureStream, &captured));
    NV_CUDA(cudaGraphInstantiate(&Exec, Graph, 0));
    return true;
  }
  catch (const std::exception& e)
  {
    if (capturing)
    {
      cudaGraph_t ignored = nullptr;
      cudaStreamEndCapture(CaptureStream, &ignored);
    }
    cudaGetLastError();
    releaseGraph();
    GraphError = e.what();
    return false;
  }
#else
  (void)b;
  GraphError = "built with CUDA " + std::to_string(CUDART_VERSION) + " (a device-side loop needs 12.4)";
  return false;
#endif
}

void StreamingLoop::runOnHost(const Batch& b, cudaStream_t stream, RenderStats& st)
{
  uint32_t* more = HostMore.get();
  do
  {
    enqueueBatch(b, stream, 0, false);
    NV_CUDA(cudaMemcpyAsync(more, &b.counters->loop.more, sizeof(uint32_t), cudaMemcpyDeviceToHost, stream));
    NV_CUDA(cudaStreamSynchronize(stream));
    ++st.wavefrontHostSyncs;
  } while (*more);
}

void StreamingLoop::trace(const ray::Params& P, int K, uint32_t sample, float4* image, float4* accum,
  RenderCounters* counters, cudaStream_t stream, bool newPicture, RenderStats& st)
{
  const int64_t pixels = int64_t(P.width) * P.height;
  Batch b;
  b.params = P;
  b.K = K;
  b.stride = K * ray::queriesPerStep(P);
  // Rays per batch: their slots (K steps of queriesPerStep queries each) hold at most the batch's queries -- at most
  // one inference chunk, so that no launch of a chunk past the batch's queries is enqueued in vain.
  const int64_t queries = Network.options.streamBatchQueries > 0 ? Network.options.streamBatchQueries :
    std::min(kMaxStreamQueries, inferenceChunk(Network));
  b.rays = static_cast<uint32_t>(std::max<int64_t>(1, std::min<int64_t>(pixels, queries / b.stride)));
  b.capacity = int64_t(b.rays) * b.stride;
  b.image = image;
  b.accum = accum;
  b.counters = counters;
  reserve(pixels, b);
  if (newPicture || !Exec)
    releaseGraph();

  NV_CUDA(cudaMemsetAsync(&counters->loop, 0, sizeof(StreamLoopState), stream));
  initRaysKernel<<<gridFor(pixels), 256, 0, stream>>>(P, sample, Rays.get(), Active[0].get(), counters, image, accum);
  NV_CUDA_LAUNCH();
  if (!Exec && !GraphFailed && !buildGraph(b))
    fallBack();
  if (Exec)
  {
    const cudaError_t e = cudaGraphLaunch(Exec, stream);
    if (e == cudaSuccess)
      return;
    GraphError = std::string("cudaGraphLaunch: ") + cudaGetErrorString(e);
    cudaGetLastError();
    releaseGraph();
    fallBack();
  }
  runOnHost(b, stream, st);
}

void StreamingLoop::fallBack()
{
  GraphFailed = true;
  postWarning("Sample Streaming: the GPU's wavefront loop cannot run as a CUDA graph (" + GraphError +
    "); the host drives it, waiting for the GPU after every batch");
}

} // namespace gpu
} // namespace nv
