// NeuralVolume engine: the GPU renderer of a session (every render path and shading mode).
#pragma once

#include "Core/Render.h"
#include "GpuInternal.cuh"

namespace nv
{
namespace gpu
{

class GpuRenderer
{
public:
  /// `dm`: the session's device model (read by the network paths); `stream`: the session's stream.
  GpuRenderer(const DeviceModel& dm, cudaStream_t stream);
  ~GpuRenderer();
  void render(const Model& model, uint64_t version, const RenderRequest& request, RenderResult& result,
    Memory where);
  int64_t deviceMemoryBytes() const;

private:
  const DeviceModel& Dm;
  cudaStream_t St;
};

} // namespace gpu
} // namespace nv
