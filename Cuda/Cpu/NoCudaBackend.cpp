// NeuralVolume engine: the CUDA entry points of a build without a CUDA compiler (see Core/Backends.h).
#include "Core/Backends.h"
#include "Core/Error.h"
#include "Core/GlImageTarget.h"

namespace nv
{

bool cudaBackendUsable(std::string* why, int)
{
  if (why)
    *why = "this build has no CUDA support";
  return false;
}

int cudaBackendDeviceCount()
{
  return 0;
}

bool cudaDeviceMemory(int64_t& freeBytes, int64_t& totalBytes, int)
{
  freeBytes = totalBytes = 0;
  return false;
}

std::unique_ptr<NetworkSession> createCudaSession(const Model&, const SessionOptions&)
{
  NV_THROW("CUDA device requested but this build of NeuralVolume has no CUDA support");
}

std::unique_ptr<GlImageTarget> GlImageTarget::create(unsigned int, int, int)
{
  NV_THROW("this build of NeuralVolume has no CUDA support (no CUDA-OpenGL interop)");
}

} // namespace nv
