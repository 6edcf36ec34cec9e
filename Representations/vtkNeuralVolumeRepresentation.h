/**
 * @class   vtkNeuralVolumeRepresentation
 * @brief   "Neural Volume" representation: volume rendering of a trained neural network
 *
 * A vtkImageVolumeRepresentation whose volume mapper is a vtkNeuralVolumeMapper: instead of the
 * image's arrays it renders the network stored in the image's field data (`NeuralNetwork`,
 * written by the Neural Compress filter) with the NeuralVolume engine. Colour and opacity maps,
 * Shade, lighting coefficients, scattering anisotropy, the opacity unit distance and the blend mode
 * come from the stock volume properties (the ParaView proxy shares them with the Volume
 * representation); the engine's own settings (render path, shading mode, sampling, path tracing,
 * light, decode resolution) are forwarded to the mapper. The Get* methods report the last render
 * (information properties of the proxy).
 */
#ifndef vtkNeuralVolumeRepresentation_h
#define vtkNeuralVolumeRepresentation_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkImageVolumeRepresentation.h"
#include "vtkNew.h"          // for vtkNew
#include "vtkSmartPointer.h" // for vtkSmartPointer

class vtkNeuralVolumeMapper;

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralVolumeRepresentation
  : public vtkImageVolumeRepresentation
{
public:
  static vtkNeuralVolumeRepresentation* New();
  vtkTypeMacro(vtkNeuralVolumeRepresentation, vtkImageVolumeRepresentation);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /// Forwarded to vtkNeuralVolumeMapper (see there).
  void SetRenderPath(int path);
  void SetShadingMode(int mode);
  void SetSampleDistance(double distance);
  void SetStreamingSamples(int k);
  void SetSamplesPerPixel(int spp);
  void SetMaxBounces(int bounces);
  void SetTargetSamples(int spp);
  void SetDenoise(int denoise);
  void SetFollowViewLight(int follow);
  void SetLightDirection(double x, double y, double z);
  void SetEmptySpaceSkipping(int skip);
  void SetDecodeResolution(int x, int y, int z);
  void SetInteractiveImageScale(double scale);
  void SetAdaptiveInteractiveScale(int adaptive);
  void SetMaximumInteractiveFrameRate(double framesPerSecond);
  void SetProgressiveRefinement(int progressive);
  void SetCudaGLInterop(int interop);
  ///@}

  ///@{
  /// The last render (see vtkNeuralVolumeMapper).
  int GetLastRenderPath();
  double GetLastSamplesEvaluated();
  double GetLastSamplesPlain();
  double GetLastWavefronts();
  int GetLastAccumulatedFrames();
  int GetLastAccumulatedPaths();
  int* GetLastImageSize() VTK_SIZEHINT(2);
  double GetLastRenderMilliseconds();
  double* GetLastFrameTimings() VTK_SIZEHINT(8);
  const char* GetLastDisplayPath();
  int GetEngineRenderCount();
  int GetWorkPending();
  int GetSessionFromBytes();
  int GetMapperHasNetwork();
  ///@}

  /// 1 when the last input carried a NeuralNetwork array.
  vtkGetMacro(HasNetwork, int);

  vtkNeuralVolumeMapper* GetNeuralMapper();

  /// What ParaView's data-range queries see (vtkPVRepresentedDataInformation: Rescale to Data Range, the automatic
  /// rescale modes, the colouring box): the input, plus -- when it holds the network but not the decoded field --
  /// a two-value array under the network's array name (field data NeuralArrayName and NeuralArrayAssociation)
  /// holding the network's value range (NeuralValueRange). That array is for the range only and is never rendered.
  vtkDataObject* GetRenderedDataObject(int port) override;

  /// Before each render: while the view captures a screenshot the mapper draws the final picture of the requested
  /// size (a progressive view would otherwise give the picture refined so far, or one of the view's earlier size).
  int ProcessViewRequest(vtkInformationRequestKey* request, vtkInformation* inInfo, vtkInformation* outInfo) override;

protected:
  vtkNeuralVolumeRepresentation();
  ~vtkNeuralVolumeRepresentation() override;

  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  int HasNetwork = 0;
  bool ReportedMissing = false;
  int LastImageSize[2] = { 0, 0 };
  double LastFrameTimings[8] = {};
  vtkNew<vtkNeuralVolumeMapper> NeuralMapper;
  vtkSmartPointer<vtkDataObject> RepresentedData; ///< see GetRenderedDataObject

private:
  vtkNeuralVolumeRepresentation(const vtkNeuralVolumeRepresentation&) = delete;
  void operator=(const vtkNeuralVolumeRepresentation&) = delete;
};

#endif
