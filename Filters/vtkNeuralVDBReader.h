/**
 * @class   vtkNeuralVDBReader
 * @brief   reads a float, double or half grid of an OpenVDB file as an image for Neural Compress
 *
 * The output covers the grid's active-voxel bounding box (index space) with the grid's transform: its
 * voxel size and translation as spacing and origin, a rotation as the image's direction matrix; only
 * linear (affine) transforms are supported. Inactive voxels hold the background value. GridName picks
 * the grid (default: the first float, double or half grid). Errors (no such file, not a VDB, no
 * scalar grid, a non-linear transform, a huge bounding box) are reported with vtkErrorMacro and give
 * an empty output. Built when OpenVDB is found (Debian: libopenvdb-dev).
 */
#ifndef vtkNeuralVDBReader_h
#define vtkNeuralVDBReader_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkImageAlgorithm.h"

#include <memory>

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralVDBReader : public vtkImageAlgorithm
{
public:
  static vtkNeuralVDBReader* New();
  vtkTypeMacro(vtkNeuralVDBReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// The grid to read; empty: the first float, double or half grid.
  vtkSetStringMacro(GridName);
  vtkGetStringMacro(GridName);

  /// Active voxels of the grid read last (its sparsity), after RequestData.
  vtkGetMacro(ActiveVoxels, vtkIdType);

  int CanReadFile(const char* name);

protected:
  vtkNeuralVDBReader();
  ~vtkNeuralVDBReader() override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkNeuralVDBReader(const vtkNeuralVDBReader&) = delete;
  void operator=(const vtkNeuralVDBReader&) = delete;

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
  char* FileName = nullptr;
  char* GridName = nullptr;
  vtkIdType ActiveVoxels = 0;
};

#endif
