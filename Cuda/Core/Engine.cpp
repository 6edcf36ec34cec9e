#include "Engine.h"

#include "Backends.h"
#include "Error.h"

namespace nv
{

bool cudaAvailable(std::string* why)
{
  return cudaBackendUsable(why);
}

Device resolveDevice(Device requested, std::string* message)
{
  std::string why;
  switch (requested)
  {
    case Device::Cpu:
      return Device::Cpu;
    case Device::Cuda:
      if (!cudaAvailable(&why))
      {
        NV_THROW("CUDA device requested but not usable: " + why);
      }
      return Device::Cuda;
    case Device::Auto:
      if (cudaAvailable(&why))
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
