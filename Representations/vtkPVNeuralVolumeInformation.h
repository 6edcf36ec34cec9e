/**
 * @class   vtkPVNeuralVolumeInformation
 * @brief   what the last Neural Volume render did, gathered from the render server
 *
 * ParaView reads a representation's information properties on the client when the representation
 * also lives there (as every representation does), so in a client-server session they do not see
 * the render server's mapper. This information object is gathered where the rendering happens
 * (vtkSMProxy::GatherInformation with vtkPVSession::RENDER_SERVER, from the NeuralVolumeRepresentation
 * proxy); vtkNeuralVolumeRefreshDriver uses it to know whether a view is still refining.
 */
#ifndef vtkPVNeuralVolumeInformation_h
#define vtkPVNeuralVolumeInformation_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkPVInformation.h"

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkPVNeuralVolumeInformation : public vtkPVInformation
{
public:
  static vtkPVNeuralVolumeInformation* New();
  vtkTypeMacro(vtkPVNeuralVolumeInformation, vtkPVInformation);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// From a vtkNeuralVolumeRepresentation (anything else leaves the defaults).
  void CopyFromObject(vtkObject* object) override;
  /// Root only: the other ranks add nothing.
  void AddInformation(vtkPVInformation* other) override;
  void CopyToStream(vtkClientServerStream* stream) override;
  void CopyFromStream(const vtkClientServerStream* stream) override;

  vtkGetMacro(Valid, bool);
  vtkGetMacro(HasNetwork, bool);
  vtkGetMacro(WorkPending, bool);
  vtkGetMacro(EngineRenderCount, int);
  vtkGetMacro(RenderPath, int);
  vtkGetMacro(AccumulatedFrames, int);
  vtkGetMacro(SamplesEvaluated, double);
  vtkGetMacro(SessionFromBytes, bool);

protected:
  vtkPVNeuralVolumeInformation();
  ~vtkPVNeuralVolumeInformation() override;

  bool Valid = false;
  bool HasNetwork = false;
  bool WorkPending = false;
  int EngineRenderCount = 0;
  int RenderPath = 0;
  int AccumulatedFrames = 0;
  double SamplesEvaluated = 0.0;
  bool SessionFromBytes = false;

private:
  vtkPVNeuralVolumeInformation(const vtkPVNeuralVolumeInformation&) = delete;
  void operator=(const vtkPVNeuralVolumeInformation&) = delete;
};

#endif
