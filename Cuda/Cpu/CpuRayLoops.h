// NeuralVolume engine: the CPU renderer's ray loops. Every path runs the shared state machine (Core/RayMachine.h)
//   initRay; while (phase != Done) { n = emit(P, r, K, q); evaluate q -> v; consume(P, r, K, v, n); }; result
// and differs only in how the queries get their values:
//   Decode          per ray, K = 1, trilinear lookup in a decoded grid;
//   In-Shader       per ray, K = 1, the network evaluated inline with the GPU's fp16 numerics (CpuHalfNetwork);
//   SampleStreaming wavefront: every live ray emits up to K steps, all queries go through one fp32 batched
//                   inference on the pool, rays consume in order, finished rays are retired and the list compacted.
#pragma once

#include "Core/RayMachine.h"
#include "Core/Render.h"

#include <cstdint>

namespace nv
{

class ThreadPool;
class CpuGridSampler;
class CpuHalfNetwork;
class CpuInference;

struct TraceCounters
{
  int64_t evaluated = 0;  ///< queries evaluated (grid lookups or network evaluations)
  int64_t plain = 0;      ///< sum of Ray::plain
  int64_t wavefronts = 0; ///< Sample Streaming batches
  bool cancelled = false; ///< control->cancel stopped the trace: rgba holds part of the image
};

/// `spp` paths per pixel (path s: initRay(..., s); P.frame is the first path index of this render). Each trace adds
/// the sum of a pixel's path results to rgba (width * height * 4, row 0 at the bottom). `control` (may be null): the
/// trace stops when control->cancel is set (checked before every pixel, counters.cancelled) and adds the rays it
/// finishes to control->raysFinished.
void traceDecode(ThreadPool& pool, const ray::Params& P, int spp, const CpuGridSampler& grid, float* rgba,
  RenderControl* control, TraceCounters& counters);
void traceInShader(ThreadPool& pool, const ray::Params& P, int spp, const CpuHalfNetwork& net, float* rgba,
  RenderControl* control, TraceCounters& counters);
/// At most `queryBudget` queries per wavefront (live rays = queryBudget / (K * queries per step), at least 1024);
/// rays beyond that wait and are admitted as others finish. The batch is inferred in slices of kInferenceSlice
/// queries (the same values: every query is evaluated on its own); control->cancel is checked between them.
void traceStreaming(ThreadPool& pool, const ray::Params& P, int spp, int K, const CpuInference& net, float* rgba,
  RenderControl* control, TraceCounters& counters, int64_t queryBudget = int64_t(1) << 21);

/// Sample Streaming: queries per inference slice (a cancelled render stops within one slice, ~10 ms on 2 cores).
constexpr int64_t kInferenceSlice = int64_t(1) << 15;

/// Emit/consume iterations after which a ray is declared runaway (nv::Error): far beyond any valid request.
constexpr int64_t kMaxRayIterations = int64_t(1) << 26;

} // namespace nv
