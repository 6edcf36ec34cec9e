// NeuralVolume engine: the GPU renderer of a session (every render path and shading mode). Owns its device state,
// created on first use and kept: transfer-function table, macrocell ranges and majorants, the decoded grid as a 3D
// texture, the image and path-tracing accumulation buffers, the wavefront buffers of Sample Streaming. Each piece is
// refreshed only when what it depends on changes (network version, resolution, transfer function, request).
#pragma once

#include "Core/Render.h"
#include "Core/RenderSetup.h"
#include "Core/Surroundings.h"
#include "GpuDenoiser.cuh"
#include "GpuInternal.cuh"
#include "GpuRenderCommon.cuh"
#include "GpuStreamingLoop.cuh"

#include <cstdint>

namespace nv
{
namespace gpu
{

/// A float 3D texture (trilinear filtering, clamped, unnormalised coordinates) over a cudaArray; move-only owner.
class GridTexture
{
public:
  GridTexture() = default;
  ~GridTexture() { release(); }
  GridTexture(const GridTexture&) = delete;
  GridTexture& operator=(const GridTexture&) = delete;
  /// (Re)create for nx * ny * nz floats and copy them from device memory.
  void assign(const float* device, int64_t nx, int64_t ny, int64_t nz, cudaStream_t stream);
  cudaTextureObject_t texture() const { return TextureObject; }
  size_t bytes() const { return Bytes; }
  void release();

private:
  cudaArray_t Array = nullptr;
  cudaTextureObject_t TextureObject = 0;
  int64_t Dims[3] = { 0, 0, 0 };
  size_t Bytes = 0;
};

class GpuRenderer
{
public:
  /// `dm`: the session's device model (read by the network paths); `stream`: the session's stream.
  GpuRenderer(const DeviceModel& dm, cudaStream_t stream);
  ~GpuRenderer();
  void render(const Model& model, uint64_t version, const RenderRequest& request, RenderResult& result,
    Memory where);
  int64_t deviceMemoryBytes() const;
  /// Recorded after the last render's kernels (they read the session's network): a publish waits for it.
  cudaEvent_t lastRenderEnd() const { return End.get(); }

private:
  /// Which lattice the current macrocell ranges were computed from.
  struct RangeKey
  {
    int kind = 0; ///< 0 none, 1 decoded / reference grid, 2 network lattice
    uint64_t version = 0;
    int64_t dims[3] = { 0, 0, 0 };
    const void* data = nullptr;
    bool operator==(const RangeKey& o) const
    {
      return kind == o.kind && version == o.version && dims[0] == o.dims[0] && dims[1] == o.dims[1] &&
        dims[2] == o.dims[2] && data == o.data;
    }
  };

  /// One frame's image (not the cached one): scene preparation, the samples, the path-tracing average, stats.
  /// `deferred` (RenderRequest::deferDeviceSync, a render to device memory): returns once the work is queued, with
  /// the previous render's GPU figures.
  void renderImage(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s,
    uint64_t imageKey, RenderStats& st, bool deferred);
  /// Waits for the last render's counters (if not yet collected) and keeps its GPU figures in LastGpuFigures.
  void collectGpuFigures();
  /// Everything a frame reads besides the network, made current; true if GPU work was enqueued for it (decoding,
  /// macrocells, masks), false when a frame only moved the camera.
  bool prepareScene(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s,
    ray::Params& P);
  bool uploadMasks(const Model& model, uint64_t version, ray::Params& P);
  /// request.denoise: the ray-marched picture of the request into Guide unless it has the one of `accumKey`.
  void prepareGuide(const Model& model, uint64_t version, const RenderRequest& q, uint64_t accumKey, RenderStats& st);
  /// Path tracing after the frame's paths: its moments, the average into Image, denoised with request.denoise.
  void resolveAccumulation(const RenderRequest& q, int spp, RenderStats& st);
  void traceSamples(const RenderRequest& q, const RenderSetup& s, ray::Params& P, int spp, float4* accum,
    RenderStats& st);
  // Each returns whether it had work to do (its inputs changed).
  bool prepareGrid(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s);
  /// occupancy: a sparse source's occupancy mask in device memory (null: none), background normalised.
  bool prepareRanges(const Model& model, uint64_t version, const RenderRequest& q, const RenderSetup& s,
    const uint32_t* occupancy, float background);
  bool prepareMajorants(const RenderSetup& s, ray::Params& P);
  /// The request's surroundings grid (RaySurroundings.h) normalised on the host and uploaded when it changes;
  /// P.surround points at the device copy (null when the request's mode does not use one).
  bool prepareSurroundings(const RenderRequest& q, const RenderSetup& s, ray::Params& P);

  const DeviceModel& Network;
  cudaStream_t RenderStream;
  DeviceBuffer<float> Tf, Majorant, Lattice, GridLinear, Depth;
  DeviceBuffer<float2> Range;
  GridTexture Grid;
  int64_t GridDims[3] = { 0, 0, 0 };
  uint64_t GridVersion = 0;
  std::chrono::steady_clock::time_point GridTime;   ///< when Grid was decoded
  std::chrono::steady_clock::time_point RangesTime; ///< when Range was computed
  bool OlderField = false; ///< this frame's grid or ranges come from an older network version
  DeviceBuffer<uint32_t> Domain; ///< SourceInfo::domain on the device
  uint64_t DomainVersion = ~0ull;
  DeviceBuffer<uint32_t> Occupancy; ///< SourceInfo::occupancy on the device
  SurroundingsCache Surroundings;   ///< the request's surroundings grid, normalised on the host
  DeviceBuffer<float> SurroundingsValues; ///< its device copy
  uint64_t OccupancyVersion = ~0ull;
  const void* GridSource = nullptr;
  RangeKey Ranges;
  uint64_t RangeStamp = 0;   ///< increments whenever Range changes
  uint64_t MajorantKey = 0;  ///< hash of (RangeStamp, table, mapping)
  uint64_t TfKey = 0;        ///< hash of the transfer-function table in Tf (RenderSetup::tableKey)
  float MaxMajorant = 0.0f;
  DeviceBuffer<float4> Image, Accum;
  int64_t Pixels = 0;
  uint64_t AccumKey = 0;     ///< request key + version + path of the accumulated image
  int Frames = 0;
  int64_t Paths = 0;         ///< paths per pixel in Accum
  // The denoiser: the accumulation's sums before the frame in flight and its second moments, the guide (the
  // ray-marched picture of GuideKey's accumulation).
  GpuDenoiser Denoiser;
  DeviceBuffer<float4> FrameStart, Guide;
  DeviceBuffer<float> Moments;
  uint64_t GuideKey = 0;
  uint64_t ImageKey = 0;     ///< ray marching: key of the image in Image (0: none)
  RenderStats ImageStats;
  DeviceBuffer<RenderCounters> Counters;
  PinnedBuffer<RenderCounters> HostCounters;
  StreamingLoop Streaming;   ///< Sample Streaming's wavefront loop and buffers
  PinnedBuffer<uint32_t> HostScalars;
  Event Begin, End;
  Event Traced;               ///< path tracing: the frame's paths done (the denoiser's time runs from it to End)
  Event CountersCopied;       ///< after the last render's counters reached HostCounters
  bool FiguresPending = false; ///< the last render's counters and times are not in LastGpuFigures yet
  bool FiguresPathTrace = false;
  bool FiguresDenoised = false; ///< the last render denoised (its denoiseMilliseconds is Traced -> End)
  RenderStats LastGpuFigures; ///< renderMilliseconds, denoiseMilliseconds, samplesEvaluated, samplesPlain,
                              ///< wavefronts of the last collected render
};

} // namespace gpu
} // namespace nv
