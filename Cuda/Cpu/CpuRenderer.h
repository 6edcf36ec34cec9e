// NeuralVolume engine: the CPU renderer -- every render path x every shading mode on a thread pool.
//
// One object per network session, created once with the session's pool. Caches, keyed on the network version:
// the decoded grid of the Decode path (progressive: a coarse grid first while the full one decodes in the
// background), the macrocell lattice of the network paths, the macrocell ranges (per lattice) and majorants (per
// transfer function), the path-tracing accumulation (continues while RenderSetup::key, the version, the field and
// the image size stay the same and request.accumulate is set), and the last deterministic image (an identical
// request returns it without tracing; stats.reused tells).
#pragma once

#include "Core/Model.h"
#include "Core/Render.h"
#include "Core/Surroundings.h"
#include "CpuDenoiser.h"
#include "CpuGridDecoder.h"
#include "CpuHalfNetwork.h"
#include "CpuMacrocells.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

namespace nv
{

class ThreadPool;

struct CpuRendererOptions
{
  /// Decode path: grids with more samples than this are decoded progressively (2^21: about 128^3, which takes
  /// about a second with the paper's network on 2 cores).
  int64_t progressiveSamples = int64_t(1) << 21;
  /// Network paths: the macrocell lattice has the source's samples per axis, at most this many.
  int latticeMax = 128;
  /// Network paths: network probes per macrocell that widen its range (CpuMacrocells::updateRanges), at most
  /// maxProbes in all (at least 4 per cell). 0: no probes, a fixed margin of kNetworkRangeMargin instead (what the
  /// GPU renderer does: with latticeMax = kMaxLatticeSamples both backends then have the same macrocells).
  int probesPerCell = 32;
  int64_t maxProbes = int64_t(1) << 18;
};

class CpuRenderer
{
public:
  explicit CpuRenderer(ThreadPool& pool, const CpuRendererOptions& options = CpuRendererOptions());
  ~CpuRenderer(); ///< cancels and joins a background decode
  CpuRenderer(const CpuRenderer&) = delete;
  CpuRenderer& operator=(const CpuRenderer&) = delete;

  /// Render `request` of `model`, whose parameters have version `version` (caches key on it). Throws nv::Error for
  /// an invalid request or model. request.control->cancel set before or during the render stops it early
  /// (stats.cancelled, empty image; the caches and the path-tracing accumulation are left as if it never ran, except
  /// that a path-tracing accumulation of the same request starts over).
  void render(const Model& model, uint64_t version, const RenderRequest& request, RenderResult& result);

  /// True while the last render was a Decode render whose full grid is still decoding in the background or has not
  /// been shown yet: render again. (A render by another path leaves the job running but does not ask for more.)
  bool workPending() const;

  /// The Decode path's full grid of `dims` for network version `version` when the renderer has it (else null).
  std::shared_ptr<const DecodedGrid> decodedGrid(uint64_t version, const int64_t dims[3]) const
  {
    return Decoder.cached(version, dims);
  }

  /// The macrocells of the last render (tests and statistics).
  const CpuMacrocells& macrocells() const { return Cells; }


private:
  std::shared_ptr<const DecodedGrid> referenceGrid(const Model& model, const VolumeView& grid);
  /// Null when `control` cancelled it.
  /// The network's lattice for the macrocell ranges: the cached one while it serves `request` (an older version's
  /// too, RenderRequest::liveRefreshMilliseconds: `older` set), else decoded now (null when cancelled).
  std::shared_ptr<const DecodedGrid> networkLattice(const Model& model, uint64_t version, const RenderRequest& request,
    bool& older);

  void renderImpl(const Model& model, uint64_t version, const RenderRequest& request, RenderResult& result);
  // renderImpl's steps, in order, on one render's state (Frame, CpuRenderer.cpp).
  struct Frame;
  /// The field (Decode: the grid; network paths: the lattice) and its macrocells, ranges and majorants; the ray
  /// parameters' pointers. False when the request's control cancelled the lattice's decode.
  bool prepareField(const Model& model, uint64_t version, const RenderRequest& request, Frame& frame);
  /// The ray parameters' pointers to the field's tables (transfer function, majorants, occupancy, depth).
  void bindField(const RenderRequest& request, Frame& frame);
  /// request.denoise: the ray-marched picture of the frame's request into Guide unless it has it (keyed on the
  /// picture's key). False when the request's control cancelled it.
  bool prepareGuide(const Model& model, uint64_t version, const RenderRequest& request, Frame& frame);
  /// Where the paths go: the path-tracing accumulation (continued or restarted), else a fresh image; params.frame.
  void chooseTarget(const RenderRequest& request, Frame& frame);
  /// The rays traced by the request's path (a failure restarts the accumulation).
  void trace(const Model& model, uint64_t version, const RenderRequest& request, Frame& frame);
  /// The result: no image when cancelled, else the averaged accumulation or the image (kept when deterministic).
  void finishImage(const RenderRequest& request, Frame& frame, RenderResult& result);
  /// Path tracing: the frame's moments, the averaged accumulation, denoised with request.denoise.
  void resolveAccumulation(const RenderRequest& request, Frame& frame, RenderResult& result);
  void resetAccumulation();
  /// The key of the kept deterministic image (the picture's key; with the paths per pixel for path tracing).
  static uint64_t deterministicKey(const RenderRequest& request, const Frame& frame);

  ThreadPool& Pool;
  CpuRendererOptions Options;
  std::atomic<bool> DecodeShown{ false }; ///< the last render showed the Decode path's decoded grid
  CpuGridDecoder Decoder;
  CpuMacrocells Cells;
  SurroundingsCache Surroundings;              ///< the request's surroundings grid, normalised

  // The request.grid of the last render, normalised (keyed on its pointer, type, dims and the source range: a
  // caller that rewrites the same buffer must pass another pointer, as RenderSetup's key hashes the pointer too).
  std::shared_ptr<const DecodedGrid> Reference;
  const void* ReferenceData = nullptr;
  int ReferenceType = -1;
  double ReferenceRange[2] = { 0.0, 0.0 };

  std::shared_ptr<const DecodedGrid> Lattice; ///< network paths
  CpuHalfTable HalfTable;                     ///< In-Shader: the fp16 hash table

  // Path-tracing accumulation: the paths' sums, the second moments of the frames' luminance (the denoiser's
  // variance), the sums before the frame in flight.
  std::vector<float> Accum, Moments, FrameStart;
  uint64_t AccumKey = 0;
  int AccumFrames = 0;
  int64_t AccumPaths = 0;

  // The denoiser and its guide (the ray-marched picture of the accumulation's key).
  CpuDenoiser Denoiser;
  std::vector<float> Guide, Denoised;
  uint64_t GuideKey = 0;

  // The last deterministic image.
  std::vector<float> Image;
  uint64_t ImageKey = 0;
  RenderStats ImageStats;
};

} // namespace nv
