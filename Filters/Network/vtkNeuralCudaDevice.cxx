#include "vtkNeuralCudaDevice.h"

#include "Core/Engine.h"

#include <vtkMultiProcessController.h>

#include <atomic>
#include <future>
#include <mutex>

namespace
{
std::atomic<int> ChosenDevice{ -1 };
std::once_flag ContextStarted;
std::future<void> ContextCreation; ///< waited for at exit (a future of std::async joins its thread)
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

//------------------------------------------------------------------------------
void vtkNeuralCudaDevice::CreateContextInBackground()
{
  vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
  if (controller && controller->GetNumberOfProcesses() > 1)
    return;
  std::call_once(ContextStarted, [] {
    const int device = ChosenDevice.load();
    ContextCreation = std::async(std::launch::async, [device] { nv::cudaCreateContext(device); });
  });
}
