// The NeuralVolume plugin's initializer (paraview_add_plugin INITIALIZERS): runs when the plugin is loaded, in
// every process. In a process with a server-manager proxy manager (the GUI, pvpython, pvbatch; not a pvserver)
// it installs the client-side helpers of the Neural Volume representation, once: vtkNeuralVolumeProxyObserver
// (colour by the network on show, the stock Volume Rendering panel group, blend modes) and
// vtkNeuralVolumeRefreshDriver (re-renders the GUI's views while a render is refining).
#ifndef vtkNeuralVolumePluginInitializer_h
#define vtkNeuralVolumePluginInitializer_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro

NEURALVOLUMEREPRESENTATIONS_EXPORT void vtkNeuralVolumePluginInitialize();

#endif
