// Private to NeuralVolume::Representations: the properties panel of an image's representation adapted for Neural
// Volume (see vtkNeuralVolumePanel.cxx). Used by vtkNeuralVolumeProxyObserver when such a representation registers.
#ifndef vtkNeuralVolumePanel_h
#define vtkNeuralVolumePanel_h

class vtkSMProxy;

namespace vtkNeuralVolumePanel
{
/// Decorates `representation`'s properties and groups (once per representation proxy).
void Adapt(vtkSMProxy* representation);
}

#endif
