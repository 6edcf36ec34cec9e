/**
 * @class   vtkNeuralVDBReader
 * @brief   reads a float, double or half grid of an OpenVDB file as an image for Neural Compress
 *
 * The output covers the grid's active-voxel bounding box (index space) with the grid's transform: its
 * voxel size and translation as spacing and origin, a rotation as the image's direction matrix; only
 * linear (affine) transforms are supported. Inactive voxels hold the background value. GridName picks
 * the grid (default: the first float, double or half grid). Errors (no such file, not a VDB, no
 * scalar grid, a non-linear transform, a huge bounding box) are reported with vtkErrorMacro and give
 * an empty output. Before OpenVDB reads a file, nv::VdbFileCheck (Cuda/Core/VdbFileCheck.h) checks its headers
 * against its size (a truncated, empty or corrupt file is refused with one message naming what is wrong); every
 * exception OpenVDB throws (std::bad_alloc and unknown ones included) becomes one message of at most a few hundred
 * characters. Built when OpenVDB is found (Debian: libopenvdb-dev).
 *
 * OutputType ACTIVE_VOXELS (1) gives a vtkPolyData instead, allocated in proportion to the active voxels only
 * (never to the bounding box): one point per active voxel (tiles expanded to their voxels, background-valued
 * active voxels included; OpenVDB's iteration order) at the voxel centre's world position, one VTK_VERTEX cell
 * per point; point data: the values (the dense image's array name and type, active scalars) and "VDBCoordinate"
 * (int, 3 components: the voxel's index-space i, j, k); field data: "VDBBackground" (double, 1 value),
 * "VDBIndexBox" (int, 6 values: imin, imax, jmin, jmax, kmin, kmax of the active voxels, inclusive: the box the
 * dense image covers), "VDBIndexToWorld" (double, 16 values: the row-major 4x4 affine matrix taking (i, j, k, 1)
 * to world coordinates) and "VDBGridName" (string, 1 value).
 */
#ifndef vtkNeuralVDBReader_h
#define vtkNeuralVDBReader_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkDataObjectAlgorithm.h"

#include <memory>

class vtkPolyData;

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralVDBReader : public vtkDataObjectAlgorithm
{
public:
  static vtkNeuralVDBReader* New();
  vtkTypeMacro(vtkNeuralVDBReader, vtkDataObjectAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// The grid to read; empty: the first float, double or half grid.
  vtkSetStringMacro(GridName);
  vtkGetStringMacro(GridName);

  /// Active voxels of the grid read last (its sparsity), after RequestData.
  vtkGetMacro(ActiveVoxels, vtkIdType);

  enum OutputTypes
  {
    IMAGE = 0,         ///< vtkImageData over the active bounding box (the default)
    ACTIVE_VOXELS = 1, ///< vtkPolyData: one vertex per active voxel (see the class documentation)
  };
  /// IMAGE (dense, the default) or ACTIVE_VOXELS (sparse).
  vtkSetClampMacro(OutputType, int, IMAGE, ACTIVE_VOXELS);
  vtkGetMacro(OutputType, int);

  int CanReadFile(const char* name);

protected:
  vtkNeuralVDBReader();
  ~vtkNeuralVDBReader() override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestDataObject(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkNeuralVDBReader(const vtkNeuralVDBReader&) = delete;
  void operator=(const vtkNeuralVDBReader&) = delete;
  int RequestActiveVoxels(vtkPolyData* output);

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
  char* FileName = nullptr;
  char* GridName = nullptr;
  vtkIdType ActiveVoxels = 0;
  int OutputType = IMAGE;
};

#endif
