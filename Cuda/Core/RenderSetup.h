// NeuralVolume engine: a render request turned into the ray machine's parameters (host side, both backends).
#pragma once

#include "Macrocells.h"
#include "Model.h"
#include "RayState.h"
#include "Render.h"

#include <chrono>
#include <cstdint>
#include <vector>

namespace nv
{

/// The largest image a request may ask for (per axis).
constexpr int kMaxImageSize = 16384;
/// The most samples (sample distances) or opacity unit distances across the volume a request may ask for.
constexpr double kMaxStepsPerRay = 1 << 20;

/// Throws nv::Error with a readable message when a request cannot be rendered (empty or huge image, non-finite
/// matrices, a singular view-projection, a transfer function with fewer than 2 entries or non-finite values,
/// negative sample distance, out-of-range modes or counts).
void validate(const RenderRequest& request);

/// Everything the backends derive from a request on the host. `params` has every pointer null: the backend points
/// tf, majorant and depth at its own copies of `table`, the macrocell majorants and the request's depth.
struct RenderSetup
{
  ray::Params params{};
  std::vector<float> table; ///< transfer function as (r, g, b, extinction per world unit)
  MacrocellLayout cells{};
  int64_t gridDims[3] = { 1, 1, 1 }; ///< Decode path: grid samples per axis
  int streamingSamples = 8;         ///< K of Sample Streaming after defaults
  uint64_t key = 0;                 ///< hash of everything that changes the picture except the frame (accumulation)
  uint64_t tableKey = 0;            ///< hash of `table` and its value mapping (what the majorants depend on)
};

/// The map from values normalised to [valueMin, valueMax] (y = (v - valueMin) / (valueMax - valueMin)) to the entry
/// coordinate of the transfer function's table: y * scale + shift (ray::Params::tfScale, tfShift for the network's
/// source range). Not finite when the transfer function's range is too small for the values' range.
void transferMap(const TransferFunction& tf, double valueMin, double valueMax, float& scale, float& shift);

/// `source` gives the network's extent (dims) and value range (the transfer function is defined on source values).
/// params.frame is 0: the backend sets the path-tracing accumulation index (it restarts when `key` changes).
RenderSetup makeRenderSetup(const RenderRequest& request, const SourceInfo& source);

/// Hash of everything in a request that changes the picture (RenderSetup::key), without the rest of the setup:
/// what a caller compares to know whether the last image still holds.
uint64_t renderKey(const RenderRequest& request);

/// Whether a field derived from network version `fieldVersion` (a decoded grid, a lattice, macrocell ranges) at time
/// `derivedAt` may stand in for version `version` in a render of `request` (RenderRequest::liveRefreshMilliseconds).
inline bool fieldStillServes(uint64_t fieldVersion, std::chrono::steady_clock::time_point derivedAt, uint64_t version,
  const RenderRequest& request)
{
  if (fieldVersion == version)
    return true;
  return request.liveRefreshMilliseconds > 0.0 &&
    std::chrono::steady_clock::now() - derivedAt <
    std::chrono::duration<double, std::milli>(request.liveRefreshMilliseconds);
}

/// The request whose picture guides the path-tracing denoiser (RenderRequest::denoise): the same view, field and
/// transfer function, ray-marched by emission-absorption (noise-free colour and alpha), one sample per pixel.
inline RenderRequest denoiserGuideRequest(const RenderRequest& request)
{
  RenderRequest guide = request;
  guide.shading = ShadingMode::RayMarch;
  guide.blend = BlendMode::Composite;
  guide.samplesPerPixel = 1;
  guide.accumulate = false;
  guide.denoise = false;
  return guide;
}

/// Default K of Sample Streaming: the K sweep on an H100 (stent, 1280 x 720, ray marching; results/gpu_render_*)
/// gave 8.3 / 4.7 / 3.0 / 2.4 / 2.1 / 1.2 / 1.3 ms for K = 1 / 2 / 4 / 8 / 16 / 32 / 64.
constexpr int kDefaultStreamingSamples = 32;

} // namespace nv
