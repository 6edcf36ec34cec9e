/**
 * @class   vtkNeuralVolumeMapper
 * @brief   volume mapper that decodes a neural representation and ray casts the result
 *
 * The input is a vtkImageData whose field data carries a serialized network (`NeuralNetwork`,
 * written by vtkNeuralCompress). The mapper decodes the network to a grid of DecodeResolution
 * samples (0 0 0 = the resolution the network was trained on) spanning the trained field's
 * bounds, and renders that grid through a stock vtkMultiBlockVolumeMapper with the volume's
 * property (color and opacity transfer functions).
 *
 * Decoding is progressive: an interactive render (render window desired update rate > 1, as
 * set by vtkPVRenderView::InteractiveRender) decodes SlicesPerRender more z-slices and shows
 * the slices decoded so far; a still render decodes everything left. The decoded grid is cached
 * and only decoded again when the network (its size and checksum) or DecodeResolution changes.
 */
#ifndef vtkNeuralVolumeMapper_h
#define vtkNeuralVolumeMapper_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkVolumeMapper.h"

class vtkMultiBlockVolumeMapper;

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralVolumeMapper : public vtkVolumeMapper
{
public:
  static vtkNeuralVolumeMapper* New();
  vtkTypeMacro(vtkNeuralVolumeMapper, vtkVolumeMapper);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /// Samples per axis of the decoded grid; 0 0 0 (or any 0) = the trained field's dimensions.
  void SetDecodeResolution(int x, int y, int z);
  void SetDecodeResolution(const int r[3]) { this->SetDecodeResolution(r[0], r[1], r[2]); }
  vtkGetVector3Macro(DecodeResolution, int);
  ///@}

  ///@{
  /// Z-slices decoded per interactive render (0 = all at once).
  vtkSetClampMacro(SlicesPerRender, int, 0, VTK_INT_MAX);
  vtkGetMacro(SlicesPerRender, int);
  ///@}

  /// Slices of the current grid decoded so far, and the grid's number of slices.
  int GetDecodedSlices() const;
  int GetTotalSlices() const;
  /// How many times a (new) network or resolution started a decode (for cache tests).
  int GetDecodeCount() const;
  /// False when the input carries no usable network (nothing is rendered).
  bool HasNetwork() const;
  /// Message of the last failure to read the network ("" when none).
  const char* GetLastError() const;

  void Render(vtkRenderer* ren, vtkVolume* vol) override;
  void ReleaseGraphicsResources(vtkWindow*) override;

  /// The stock mapper that renders the decoded grid.
  vtkMultiBlockVolumeMapper* GetRenderMapper();

protected:
  vtkNeuralVolumeMapper();
  ~vtkNeuralVolumeMapper() override;

  int DecodeResolution[3] = { 0, 0, 0 };
  int SlicesPerRender = 8;

private:
  vtkNeuralVolumeMapper(const vtkNeuralVolumeMapper&) = delete;
  void operator=(const vtkNeuralVolumeMapper&) = delete;

  struct vtkInternals;
  vtkInternals* Internals;
};

#endif
