/**
 * @class   vtkNeuralCompressStateSaver
 * @brief   client-side: writes the trained networks of every Neural Compress into saved state files
 *
 * Installed once per client process by the plugin's initializer. When a state is saved (File > Save
 * State, pvpython's SaveState; the session proxy manager's SaveStateEvent) it asks each Neural
 * Compress filter for the networks it holds (the TrainedNetworksInfo property, from the data
 * server) and writes them as the value of the filter's TrainedNetworks property in the state. On
 * loading, that property hands them back to the new filter, which reuses a network only when its key
 * (input values and settings) matches: the state comes back without training.
 */
#ifndef vtkNeuralCompressStateSaver_h
#define vtkNeuralCompressStateSaver_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkObject.h"

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralCompressStateSaver : public vtkObject
{
public:
  static vtkNeuralCompressStateSaver* New();
  vtkTypeMacro(vtkNeuralCompressStateSaver, vtkObject);

  /// Observe the proxy manager of this process (once).
  void Install();

protected:
  vtkNeuralCompressStateSaver() = default;
  ~vtkNeuralCompressStateSaver() override;

private:
  vtkNeuralCompressStateSaver(const vtkNeuralCompressStateSaver&) = delete;
  void operator=(const vtkNeuralCompressStateSaver&) = delete;

  void OnSaveState(vtkObject*, unsigned long, void* info);

  unsigned long Tag = 0;
};

#endif
