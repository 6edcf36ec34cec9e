#include "CpuRenderer.h"

#include "Core/Error.h"

namespace nv
{

CpuRenderer::CpuRenderer(ThreadPool& pool)
  : Pool(pool)
{
}

void CpuRenderer::render(const Model&, uint64_t, const RenderRequest&, RenderResult&)
{
  NV_THROW("the CPU renderer is not part of this build yet");
}

} // namespace nv
