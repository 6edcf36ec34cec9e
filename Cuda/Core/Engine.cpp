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
