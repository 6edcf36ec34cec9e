#include "GpuRenderer.cuh"

namespace nv
{
namespace gpu
{

GpuRenderer::GpuRenderer(const DeviceModel& dm, cudaStream_t stream)
  : Dm(dm)
  , St(stream)
{
}

GpuRenderer::~GpuRenderer() = default;

void GpuRenderer::render(const Model&, uint64_t, const RenderRequest&, RenderResult&, Memory)
{
  NV_THROW("the GPU renderer is not part of this build yet");
}

int64_t GpuRenderer::deviceMemoryBytes() const
{
  return 0;
}

} // namespace gpu
} // namespace nv
