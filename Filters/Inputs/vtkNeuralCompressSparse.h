// Neural Compress on a sparse OpenVDB grid (private header): the OpenVDB reader's "Active voxels (sparse)" output (a
// poly data of the active voxels with their index coordinates, and the grid's index box, background and transform as
// field data; vtkNeuralVDBReader.h) is trained from without a dense grid: the training bank holds every active voxel
// and random inactive voxels of the box at the background value (found through a hash set of the active coordinates),
// and the error is measured at those same samples. The output image covers the grid's box, as the reader's dense
// output does.
#ifndef vtkNeuralCompressSparse_h
#define vtkNeuralCompressSparse_h

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

class vtkDataArray;
class vtkDataObject;
class vtkIntArray;

namespace vtkNeuralCompressInternals
{
struct SourceSamples;

/// The active voxels of a sparse grid and the geometry of its index box.
struct SparseVoxels
{
  int Dims[3] = { 0, 0, 0 };           ///< voxels per axis of the box
  double Origin[3] = { 0, 0, 0 };      ///< world position of the box's first voxel
  double Spacing[3] = { 1, 1, 1 };     ///< voxel size per axis
  double Direction[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
  int BoxMin[3] = { 0, 0, 0 };         ///< index of the box's first voxel
  double Background = 0.0;
  vtkDataArray* Values = nullptr;      ///< the selected point array (one tuple per active voxel)
  vtkIntArray* Coords = nullptr;       ///< "VDBCoordinate"
};

/// True when `input` carries the OpenVDB reader's sparse output contract (its "VDBIndexBox" field data).
bool IsSparseVoxels(vtkDataObject* input);

/// The name of the sparse voxels' active scalars (the grid's values), or "".
std::string SparseScalarsName(vtkDataObject* input);

/// Reads the contract for point array `name`. False with `problem` set when it is broken (missing or inconsistent
/// arrays, coordinates outside the box, a singular transform, a box over 2^31 voxels per axis product limit).
bool ReadSparseVoxels(vtkDataObject* input, const std::string& name, SparseVoxels& voxels, std::string& problem);

/// The training bank of a sparse grid and the samples that measure it.
struct SparseBank
{
  std::vector<float> Xyz;     ///< interleaved, normalised to the box ([0,1]; 0.5 on a flat axis)
  std::vector<double> Values; ///< source units: the scalar of each active voxel, then the background samples
  int64_t Active = 0;         ///< active voxels in the bank (all of them)
  int64_t Background = 0;     ///< inactive voxels sampled at the background value
  int64_t Inactive = 0;       ///< inactive voxels of the box
  std::shared_ptr<SourceSamples> Samples; ///< the bank's points in the box frame, for the error
  /// The network's occupancy mask (nv::SourceInfo::occupancy): the macrocells whose interpolated field may differ
  /// from the background -- those holding an active voxel, and the one below along an axis where the voxel starts a
  /// cell (queries there interpolate across the boundary). The others are background exactly.
  std::vector<uint32_t> Occupancy;
};

/// Every active voxel (the scalar of its tuple: magnitude for vectorMode 0, else `component`) and
/// min(inactive voxels, max(active voxels, 2^18)) distinct inactive voxels drawn at random (seeded) at the background
/// value. Memory in proportion to the active voxels only.
bool MakeSparseBank(const SparseVoxels& voxels, int vectorMode, int component, uint64_t seed, SparseBank& bank,
  std::string& problem);

} // namespace vtkNeuralCompressInternals

#endif
