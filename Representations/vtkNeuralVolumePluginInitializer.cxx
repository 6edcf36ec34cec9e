#include "vtkNeuralVolumePluginInitializer.h"

#include "vtkNeuralCompressStateSaver.h"

#include "vtkNeuralVolumeProxyObserver.h"
#include "vtkNeuralVolumeRefreshDriver.h"
#include "vtkSMProxyManager.h"
#include "vtkSmartPointer.h"

void vtkNeuralVolumePluginInitialize()
{
  // Kept for the life of the process (the plugin is never unloaded), created once even when the plugin is
  // loaded again.
  static vtkSmartPointer<vtkNeuralVolumeProxyObserver> observer;
  static vtkSmartPointer<vtkNeuralVolumeRefreshDriver> driver;
  static vtkSmartPointer<vtkNeuralCompressStateSaver> saver;
  if (!vtkSMProxyManager::IsInitialized())
  {
    return;
  }
  if (!observer)
  {
    observer = vtkSmartPointer<vtkNeuralVolumeProxyObserver>::New();
    observer->Install();
  }
  if (!saver)
  {
    saver = vtkSmartPointer<vtkNeuralCompressStateSaver>::New();
    saver->Install();
  }
  if (!driver)
  {
    driver = vtkSmartPointer<vtkNeuralVolumeRefreshDriver>::New();
    driver->Install();
  }
}
