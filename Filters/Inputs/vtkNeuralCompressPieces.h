// MPI (private): a rank's piece of Neural Compress's input (only what training needs), and the whole input assembled
// from every rank's piece on rank 0 -- images stitched by extent (ghosts left out), other datasets merged by global
// point ids, composites and AMR with each block's pieces merged. vtkNeuralCompressDistributed.h does the communication.
#ifndef vtkNeuralCompressPieces_h
#define vtkNeuralCompressPieces_h

#include "vtkSmartPointer.h"

#include <string>
#include <vector>

class vtkAlgorithm;
class vtkDataObject;
class vtkImageData;

namespace vtkNeuralCompressInternals
{
constexpr int kRoot = 0; ///< the rank that gathers and trains

/// Field-data arrays of an image piece: its geometry (origin, spacing, direction: the legacy format that carries
/// data objects between processes writes the geometry as text) and what the rank found.
constexpr const char* kPieceGeometryName = "vtkNeuralCompressPieceGeometry";
constexpr const char* kPieceFoundName = "vtkNeuralCompressPieceArray";

/// The samples of extent `ext` per axis, [lo, hi]: its points, or its cells (one fewer on an axis that has cells).
void SampleRange(const int ext[6], bool cells, int lo[3], int hi[3]);

/// "rank 2", "ranks 1, 3": for messages.
std::string RankList(const std::vector<int>& ranks);

/// The filter's selected array: a name, or an attribute type (the active scalars) when no name is set.
struct Selection
{
  std::string Name;
  int Association = -1;
  int AttributeType = -1;
};

/// The array `self` (the filter) has selected.
Selection Selected(vtkAlgorithm* self);

/// This rank's piece of the input, reduced to what training needs (the selected array, ghost arrays, global ids).
vtkSmartPointer<vtkDataObject> MakePiece(vtkDataObject* local, const Selection& sel);

/// Rank 0: the image pieces stitched into one image of `wholeExtent` (null: the union of the pieces' extents); null
/// with `problem` set when an array is missing on a piece or the pieces do not cover the extent.
vtkSmartPointer<vtkImageData> StitchImages(
  const std::vector<vtkSmartPointer<vtkDataObject>>& pieces, const int* wholeExtent, std::string& problem);

/// Rank 0: the whole input from the pieces of a dataset or composite input (null with `problem` set on failure).
vtkSmartPointer<vtkDataObject> Assemble(const std::vector<vtkSmartPointer<vtkDataObject>>& pieces,
  const Selection& sel, std::vector<std::string>& warnings, std::string& problem);

/// A non-empty extent.
bool ValidExtent(const int* e);

} // namespace vtkNeuralCompressInternals

#endif
