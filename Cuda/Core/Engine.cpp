#include "Engine.h"

#include "Backends.h"
#include "Error.h"

namespace nv
{

bool cudaAvailable(std::string* why, int cudaDevice)
{
  return cudaBackendUsable(why, cudaDevice);
}

int cudaDeviceCount()
{
  return cudaBackendDeviceCount();
}

void cudaCreateContext(int cudaDevice) noexcept
{
  try
  {
    int64_t freeBytes = 0, totalBytes = 0;
    if (cudaBackendUsable(nullptr, cudaDevice))
      cudaDeviceMemory(freeBytes, totalBytes, cudaDevice); // its first call on a device creates the context
  }
  catch (...)
  {
    // A context that cannot be made now is made (and its error reported) by the first session.
  }
}

Device resolveDevice(Device requested, std::string* message, int cudaDevice)
{
  std::string why;
  switch (requested)
  {
    case Device::Cpu:
      return Device::Cpu;
    case Device::Cuda:
      if (!cudaAvailable(&why, cudaDevice))
      {
        NV_THROW("CUDA device requested but not usable: " + why);
      }
      return Device::Cuda;
    case Device::Auto:
      if (cudaAvailable(&why, cudaDevice))
      {
        return Device::Cuda;
      }
      if (message)
      {
        *message = "no GPU usable (" + why + "): running on the CPU";
      }
      return Device::Cpu;
  }
  return Device::Cpu;
}

} // namespace nv
