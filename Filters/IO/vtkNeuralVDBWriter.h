/**
 * @class   vtkNeuralVDBWriter
 * @brief   writes a scalar field of an image (e.g. a decoded Neural Compress output) as a sparse OpenVDB grid
 *
 * The selected point array (the image's active scalars by default, or ArrayName) becomes a float grid
 * (double for a double array) named after the array, with the image's origin, spacing and direction
 * as the grid's transform. Voxels within Tolerance of Background stay inactive (the background is
 * pruned), so a field that is mostly background gives a small file. NaN (outside a resampled source's
 * domain) is written as background. Built when OpenVDB is found.
 */
#ifndef vtkNeuralVDBWriter_h
#define vtkNeuralVDBWriter_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkAlgorithm.h"

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralVDBWriter : public vtkAlgorithm
{
public:
  static vtkNeuralVDBWriter* New();
  vtkTypeMacro(vtkNeuralVDBWriter, vtkAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);
  /// The point array to write; empty: the active scalars, else the first point array.
  vtkSetStringMacro(ArrayName);
  vtkGetStringMacro(ArrayName);
  vtkSetMacro(Background, double);
  vtkGetMacro(Background, double);
  /// Values with |value - Background| <= Tolerance are inactive (pruned).
  vtkSetClampMacro(Tolerance, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(Tolerance, double);

  /// Active voxels written last.
  vtkGetMacro(ActiveVoxels, vtkIdType);

  int Write();

protected:
  vtkNeuralVDBWriter();
  ~vtkNeuralVDBWriter() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;
  vtkTypeBool ProcessRequest(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkNeuralVDBWriter(const vtkNeuralVDBWriter&) = delete;
  void operator=(const vtkNeuralVDBWriter&) = delete;

  char* FileName = nullptr;
  char* ArrayName = nullptr;
  double Background = 0.0;
  double Tolerance = 0.0;
  vtkIdType ActiveVoxels = 0;
  bool Failed = false;
};

#endif
