/**
 * @class   vtkNeuralVolumeRepresentation
 * @brief   "Neural Volume" representation: volume rendering of a trained neural network
 *
 * A vtkImageVolumeRepresentation whose volume mapper is a vtkNeuralVolumeMapper: instead of the
 * image's arrays it renders the network stored in the image's field data (`NeuralNetwork`,
 * written by the Neural Compress filter), decoded progressively to a grid of DecodeResolution.
 * Color and opacity come from the usual transfer functions (the ParaView proxy shares them with
 * the stock Volume representation).
 *
 * RenderPath selects how the network reaches the screen: Decode (0) decodes to a grid and ray
 * casts it; Sample Streaming (1) and In-Shader (2) arrive in a later version and fall back to
 * Decode with a warning.
 */
#ifndef vtkNeuralVolumeRepresentation_h
#define vtkNeuralVolumeRepresentation_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkImageVolumeRepresentation.h"
#include "vtkNew.h" // for vtkNew

class vtkNeuralVolumeMapper;

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralVolumeRepresentation
  : public vtkImageVolumeRepresentation
{
public:
  static vtkNeuralVolumeRepresentation* New();
  vtkTypeMacro(vtkNeuralVolumeRepresentation, vtkImageVolumeRepresentation);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum RenderPaths
  {
    DECODE = 0,
    SAMPLE_STREAMING = 1,
    IN_SHADER = 2
  };

  ///@{
  /// Forwarded to vtkNeuralVolumeMapper.
  void SetDecodeResolution(int x, int y, int z);
  void SetSlicesPerRender(int slices);
  int GetDecodedSlices();
  int GetTotalSlices();
  int GetDecodeCount();
  ///@}

  ///@{
  /// DECODE, SAMPLE_STREAMING or IN_SHADER (the latter two render with DECODE for now).
  void SetRenderPath(int path);
  vtkGetMacro(RenderPath, int);
  ///@}

  /// Hides vtkImageVolumeRepresentation::SetRequestedRenderMode (which only knows the stock
  /// mappers) to forward the Volume Rendering Mode to the mapper that renders the decoded grid.
  void SetRequestedRenderMode(int mode);

  /// 1 when the last input carried a readable NeuralNetwork array.
  vtkGetMacro(HasNetwork, int);

  vtkNeuralVolumeMapper* GetNeuralMapper();

protected:
  vtkNeuralVolumeRepresentation();
  ~vtkNeuralVolumeRepresentation() override;

  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  int RenderPath = DECODE;
  int HasNetwork = 0;
  vtkNew<vtkNeuralVolumeMapper> NeuralMapper;

private:
  vtkNeuralVolumeRepresentation(const vtkNeuralVolumeRepresentation&) = delete;
  void operator=(const vtkNeuralVolumeRepresentation&) = delete;
};

#endif
