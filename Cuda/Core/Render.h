// NeuralVolume engine: what a caller asks of the renderer and what it gets back (VTK-free).
//
// One image of the network (or, for tests, of an explicit grid) seen through a camera, with a transfer function,
// a render path (how the field is evaluated) and a shading mode (what light transport is computed). The per-ray
// logic is shared by every path and both backends (RayMachine.h); the paths differ only in where the field values
// come from:
//   Decode          the network decoded once to a grid (kept until the network or the resolution changes), sampled
//                   trilinearly while marching;
//   SampleStreaming wavefront: every live ray emits the next K samples, all of them are inferred in one batch,
//                   consumed in order, and finished rays are compacted away;
//   InShader        the encoding + MLP are evaluated inside the ray-marching kernel (on the GPU the 32 lanes of a
//                   warp evaluate their samples together on the tensor cores; a lane whose ray ends takes the next
//                   pixel).
#pragma once

#include "Config.h"
#include "Volume.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

namespace nv
{

enum class RenderPath : int
{
  Decode = 0,
  SampleStreaming = 1,
  InShader = 2
};

enum class ShadingMode : int
{
  RayMarch = 0,         ///< emission-absorption
  RayMarchGradient = 1, ///< emission-absorption, Blinn-Phong with the network's gradient (central differences)
  RayMarchShadows = 2,  ///< emission-absorption, one shadow ray per visible sample towards the light
  PathTrace = 3,        ///< volumetric path tracing (delta tracking, Henyey-Greenstein phase); the light is an
                        ///< environment both modes reach: a uniform sky (ambient) and a sun lobe (diffuse, sunAngle)
  PathTraceNee = 4      ///< the same picture with next-event estimation of the sun (ratio-tracked shadow rays)
};

/// How samples along a ray are combined (ray-marching modes; path tracing always composites).
enum class BlendMode : int
{
  Composite = 0,
  Maximum = 1, ///< maximum intensity projection: the transfer function at the largest value
  Minimum = 2,
  Average = 3, ///< mean of the values inside averageRange
  Additive = 4 ///< emission without absorption: sum of opacity-weighted colours
};

const char* renderPathName(RenderPath p);
const char* shadingModeName(ShadingMode m);
const char* blendModeName(BlendMode b);

/// Colour and opacity over a range of source values (what VTK's colour and scalar opacity functions give).
struct TransferFunction
{
  std::vector<float> rgba;    ///< n >= 2 entries (r, g, b, opacity), uniform over [valueMin, valueMax]
  double valueMin = 0.0;      ///< source units; values outside the range take the end entries
  double valueMax = 1.0;
  double unitDistance = 1.0;  ///< world distance over which an entry's opacity applies (ScalarOpacityUnitDistance)
};

/// Lets another thread follow and stop a render in flight. The caller owns it (it must outlive the render) and may
/// reuse it for the next render once it has reset `cancel`. The CPU backend checks `cancel` before every pixel (per-ray
/// paths) and between wavefronts and inference slices (Sample Streaming); the CUDA backend, whose frames take
/// milliseconds, ignores it.
struct RenderControl
{
  std::atomic<bool> cancel{ false };      ///< set from any thread: the render stops early, stats.cancelled
  std::atomic<int64_t> raysFinished{ 0 }; ///< primary rays (pixel paths) the render has finished, added as it goes
};

/// A coarse grid of the field around the clip box (MPI: the whole dataset, every rank's piece), through which the
/// secondary rays of the shading modes with light transport continue once they leave the clip box: the shadow ray of
/// RayMarchShadows, the sun's shadow ray of PathTraceNee and the scattered path segments of path tracing (a path that
/// has left the clip box is traced in this grid to its end). Primary rays march the clip box only, as without it.
/// Values are looked up trilinearly with the transfer function (no network queries).
struct SurroundingsGrid
{
  std::vector<float> values; ///< dims[0] * dims[1] * dims[2] source values, x fastest; NaN: no data (transparent)
  int dims[3] = { 0, 0, 0 };  ///< samples per axis, each >= 2
  double box[6] = { 0, 1, 0, 1, 0, 1 }; ///< network coordinates of the grid's corner samples (xmin xmax ... zmax):
                                        ///< sample (i, j, k) at box lo + (i, j, k) / (dims - 1) * (hi - lo); MPI:
                                        ///< [0,1]^3 is the rank's padded piece, this box the whole dataset's
};

/// The most samples a surroundings grid may have (about 2 GiB of floats would be refused long before this; a
/// surroundings grid is meant to be coarse, e.g. 64^3 .. 96^3).
constexpr int64_t kMaxSurroundingsSamples = int64_t(1) << 27;

struct RenderRequest
{
  int width = 0;
  int height = 0;
  double viewProjection[16] = {}; ///< world -> clip, row-major, OpenGL conventions (NDC z in [-1, 1])
  double worldToUnit[16] = {};    ///< world -> network coordinates [0,1]^3, row-major affine
  double clipBox[6] = { 0, 1, 0, 1, 0, 1 }; ///< the part of [0,1]^3 rays march (network coordinates; MPI: a rank's
                                  ///< own piece of a network trained with ghost layers around it)
  TransferFunction transfer;
  RenderPath path = RenderPath::InShader;
  ShadingMode shading = ShadingMode::RayMarch;
  BlendMode blend = BlendMode::Composite;
  double sampleDistance = 0.0;    ///< world units between samples; 0 = the smallest voxel spacing of the source
  double averageRange[2] = { 0.0, 0.0 }; ///< source units; Average blend only (lo >= hi: every value)
  double lightDirection[3] = { 0.0, 0.0, 1.0 }; ///< world space, towards the light
  double lightIntensity = 1.0;
  double ambient = 0.2;
  double diffuse = 0.8;
  double specular = 0.2;
  double specularPower = 10.0;
  double sunAngle = 30.0;         ///< degrees from the light direction at which the sun's radiance lobe falls to half
                                  ///< its peak (path tracing; 0.1..90: a sharp sun .. the lit hemisphere)
  double anisotropy = 0.0;        ///< Henyey-Greenstein g of the phase function (path tracing), in (-1, 1)
  int maxBounces = 4;             ///< scattering events per path (path tracing)
  int samplesPerPixel = 1;        ///< paths per pixel per render (path tracing; an accumulation continues when it
                                  ///< changes)
  bool accumulate = true;         ///< path tracing: average with the previous renders while the request is unchanged
  bool denoise = false;           ///< path tracing: the image handed out is the accumulation denoised, guided by the
                                  ///< ray-marched picture of the same request (Core/Denoise.h; the accumulation
                                  ///< itself stays unfiltered; not in the image key)
  int streamingSamples = 0;       ///< K of Sample Streaming: samples a ray advances per wavefront; 0 = default
  bool emptySpaceSkipping = true; ///< macrocells x opacity: skip empty space (ray marching), local majorants (tracking)
  double terminationOpacity = 0.99; ///< early ray termination (>= 1: off)
  int decodeResolution[3] = { 0, 0, 0 }; ///< Decode path grid; 0 0 0 = the trained field's dimensions
  bool waitForDecode = false;     ///< Decode path: render with the full grid now, never a coarse one (a caller that
                                  ///< waits for the final picture: the CPU backend decodes it on all of the session's
                                  ///< threads, finishing a background decode already under way); not in the image key
  double liveRefreshMilliseconds = 0.0; ///< a network that changes while the view turns (training): the decoded grid
                                  ///< and the macrocell ranges of an older version stand in for the current one until
                                  ///< they are this old, then are derived again (0: for every version; not in the
                                  ///< image key). The interactive renders of the ParaView mapper set it.
  bool deferDeviceSync = false;   ///< a render to Memory::Device returns once its GPU work is queued (CUDA backend):
                                  ///< RenderResult::deviceReady orders the image's consumers after it, and the GPU
                                  ///< figures of the stats are the previous render's (gpuFiguresOfPreviousRender);
                                  ///< not in the image key. The ParaView mapper's interop path sets it.
  const float* depth = nullptr;   ///< optional width*height window depths in [0,1] of opaque geometry (row 0 bottom)
  RenderControl* control = nullptr; ///< optional cancellation and progress (CPU backend; not in the image key)
  const VolumeView* grid = nullptr; ///< Decode path only: march this volume (its own value range normalised like the
                                    ///< network's source) instead of the decoded network -- the tests' reference
  /// Optional (null: secondary rays stop at the clip box): see SurroundingsGrid. Used by RayMarchShadows, PathTrace
  /// and PathTraceNee on every path and backend; in the image key (its values hashed) for those modes.
  std::shared_ptr<const SurroundingsGrid> surroundings;
  uint64_t seed = 1;
};

struct RenderStats
{
  RenderPath path = RenderPath::Decode;
  Device device = Device::Cpu;
  int64_t rays = 0;             ///< primary rays (pixels x samples per pixel)
  int64_t samplesEvaluated = 0; ///< field evaluations (network or grid)
  int64_t samplesPlain = 0;     ///< samples a plain marcher would take (one per step from entry to termination or
                                ///< exit, no skipping); ray-marching modes only
  int64_t wavefronts = 0;       ///< Sample Streaming: batches inferred
  /// Sample Streaming: times the host waited for the GPU inside the wavefront loop (the CUDA backend: 0, the loop
  /// runs on the device as a CUDA graph; the CPU backend: 0, it has no device).
  int64_t wavefrontHostSyncs = 0;
  int accumulatedFrames = 0;    ///< path tracing: renders averaged into this image
  int64_t accumulatedPaths = 0; ///< path tracing: paths per pixel averaged into this image
  bool denoised = false;        ///< path tracing: the image is the denoised accumulation (request.denoise)
  double guideMilliseconds = 0.0;   ///< request.denoise: rendering the guide (once per picture; 0 when cached; the
                                    ///< GPU backend: the host's time to prepare and enqueue it)
  double denoiseMilliseconds = 0.0; ///< request.denoise: filtering the image
  bool decodePending = false;   ///< Decode path: a coarser grid was used, the full grid is still being decoded
  bool cancelled = false;       ///< request.control->cancel stopped the render: rgba is empty, nothing was cached or
                                ///< accumulated (render again to get the picture)
  bool gpuFiguresOfPreviousRender = false; ///< RenderRequest::deferDeviceSync: renderMilliseconds,
                                           ///< samplesEvaluated, samplesPlain and wavefronts are the previous
                                           ///< render's
  bool olderField = false;      ///< the grid or macrocell ranges of an older network version were used
                                ///< (RenderRequest::liveRefreshMilliseconds)
  bool reused = false;          ///< ray marching: the request, network and image size were unchanged, so the previous
                                ///< image was returned without rendering
  double decodeMilliseconds = 0.0;    ///< decoding and macrocell refresh done by this call
  double renderMilliseconds = 0.0;    ///< marching / tracing
  double hostCopyMilliseconds = 0.0;  ///< GPU backend, a render to Memory::Host: copying the image to the host
};

struct RenderResult
{
  std::vector<float> rgba;           ///< width * height * 4, premultiplied colour and opacity, row 0 at the bottom
  const float* deviceRgba = nullptr; ///< same layout in device memory (render to Memory::Device; GPU backend only;
                                     ///< valid until the session's next render)
  const void* deviceReady = nullptr; ///< RenderRequest::deferDeviceSync: the CUDA event (cudaEvent_t) after which
                                     ///< deviceRgba is complete (null: complete when render() returned)
  RenderStats stats;
};

} // namespace nv
