#include "vtkNeuralCudaDevice.h"

#include "Core/Engine.h"

#include <atomic>

namespace
{
std::atomic<int> ChosenDevice{ -1 };
}

//------------------------------------------------------------------------------
int vtkNeuralCudaDevice::Get()
{
  return ChosenDevice.load();
}

//------------------------------------------------------------------------------
int vtkNeuralCudaDevice::ChooseForLocalRank(int localRank)
{
  const int devices = nv::cudaDeviceCount();
  const int device = devices > 0 && localRank >= 0 ? localRank % devices : -1;
  ChosenDevice.store(device);
  return device;
}
