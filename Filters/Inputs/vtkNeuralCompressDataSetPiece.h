// Neural Compress under MPI with any dataset that is not an image (private header): one network per rank, no gather.
//
// Design (only when the global vtkMultiProcessController has more than one process and every rank's input is a
// dataset other than an image -- unstructured, structured, rectilinear grids, poly data with cells -- or a composite
// of datasets -- multiblock, partitioned collection, overlapping or non-overlapping AMR -- and not a particle set nor
// sparse voxels; images train per rank in vtkNeuralCompressPartition.h, particle sets in
// vtkNeuralCompressParticlePiece.h (on this file's lattice and regions), sparse voxels still go
// through vtkNeuralCompressDistributed.h's gather to rank 0):
// - Every rank keeps the piece its input gave it (RequestLocalPiece: piece r of N, no ghost levels; after
//   RedistributeDataSet or D3 the pieces are spatially compact; AMR readers hand each rank some blocks). One
//   all-gather of kSummaryLength numbers a rank -- its bounds, the box of its own cells' centres (ghost cells left
//   out), its sample count and bytes, the finest spacing of its image blocks -- gives every rank the same lattice: the
//   whole input's bounds sampled at SamplingDimensions or at the serial run's automatic dimensions (the summed sample
//   count, or for composites of images such as AMR their finest spacing: the serial lattice).
// - Regions: a k-d tree rebuilt from the centre boxes: the ranks are split recursively along the axis and at the
//   position where the two groups' centre boxes are farthest apart (RedistributeDataSet's and D3's k-d cuts leave a
//   gap there; pieces of any other layout -- AMR blocks dealt round-robin -- still get a tiling, split where they
//   overlap least), the cut snapped to the nearest lattice plane. The leaves are point extents of the lattice that
//   share one plane with their neighbours and tile it exactly, as the image pieces of vtkNeuralCompressPartition.h
//   do; so the rest is that path's: the owned extent grown by kPieceGhostLayers is trained, the output is cropped to
//   the owned extent with NeuralPieceBounds (the rays clipped there, ordered compositing by those bounds), the global
//   figures are all-reduced.
// - A rank's cells need not cover its region (a cell cut by a k-d plane belongs to one side, an AMR rank may hold no
//   block of part of its region) and ghost layers need cells beyond it. So each rank resamples every block it holds
//   onto every rank's padded region that the block's bounds reach (vtkResampleToImage, serial on the rank, block by
//   block) and sends each region's samples to its rank (vtkNeuralCompressPieceSampling.cxx): only lattice samples
//   travel, never cells, and no rank holds more than one padded region of them at a time. Each sample keeps the
//   block that gave it: where several blocks cover a lattice point the first in the composite's order wins, as in the
//   serial vtkResampleToImage (vtkCompositeDataProbeFilter probes the blocks in order and fills empty points only;
//   AMR cells covered by a finer level are blanked, so the finest level wins). What stays NaN is outside every
//   rank's cells: the network's domain mask, as in serial.
#ifndef vtkNeuralCompressDataSetPiece_h
#define vtkNeuralCompressDataSetPiece_h

#include "vtkImageData.h" // for vtkSmartPointer<vtkImageData>
#include "vtkSmartPointer.h"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

class vtkDataArray;
class vtkDataObject;
class vtkDataSet;

namespace vtkNeuralCompressInternals
{
/// The point or cell array `name` of a block (null when it has none).
vtkDataArray* PieceArray(vtkDataSet* block, const std::string& name, int association);

/// True for the inputs that may train per rank through DataSetPiece (a type test, the same on every rank): a
/// dataset other than an image, or a composite; not sparse voxels.
bool PerRankDataSetType(vtkDataObject* local);

/// True under MPI when every rank's input is of PerRankDataSetType and not a particle set (an empty piece counts
/// as one). A collective: every rank calls it in the same pass.
bool PerRankDataSets(vtkDataObject* local);

/// The ranks' regions of a lattice by the k-d split above: `centres[r]` the box (xmin xmax ymin ymax zmin zmax) of
/// rank r's own samples, `holders` the ranks that hold samples; point extents of `whole`, empty (lo > hi) for the
/// other ranks. Particle sets use it too (vtkNeuralCompressParticlePiece.h).
std::vector<std::array<int, 6>> LatticeRegions(const std::vector<std::array<double, 6>>& centres,
  const std::vector<int>& holders, const std::array<int, 6>& whole, const double origin[3], const double spacing[3]);

/// A rank's piece of a dataset or composite: the lattice, its region and the padded image its network trains on.
class DataSetPiece
{
public:
  /// RequestInformation (a collective): the whole lattice's dimensions; false with `problem` (the same on every
  /// rank) when no rank has the array or its values.
  bool Resolve(vtkDataObject* local, const std::string& name, int association, const int requested[3], int dims[3],
    std::string& problem);

  /// RequestData (a collective): the lattice, the regions, this rank's resampling and the exchange; false with
  /// `problem` when any rank failed (the same decision on every rank). Reuses the last piece while no rank's input,
  /// array or dimensions changed.
  bool Prepare(vtkDataObject* local, const std::string& name, int association, const int requested[3],
    std::string& problem);

  /// True when this rank owns part of the lattice (it holds cells).
  bool HasPiece() const { return this->TrainingImage != nullptr; }
  /// The padded image to train on (point array named as the input's, NaN outside every rank's cells), its point
  /// extent in the lattice's index frame.
  vtkImageData* Training() const { return this->TrainingImage; }
  const int* Owned() const { return this->OwnedExtent.data(); }
  const int* Whole() const { return this->WholeExtent.data(); }
  /// 1 for the training image's samples outside the domain (its NaN samples), for the network's domain mask.
  std::shared_ptr<std::vector<uint8_t>> Outside() const { return this->OutsideMask; }
  /// Bytes of this rank's own source samples of the array (ghosts left out): its share of the compression ratio.
  double SourceBytes() const { return this->OwnBytes; }
  /// This rank's own source samples of the array (ghosts left out).
  double SourceSamples() const { return this->OwnSamples; }
  /// "vtkUnstructuredGrid piece, 81234 cells -> 24 x 49 x 49 (...)".
  const std::string& Description() const { return this->Text; }

  /// Every rank's summary (kSummaryLength numbers): see the .cxx.
  using Summary = std::array<double, 19>;

private:
  Summary LocalSummary(vtkDataObject* local, const std::string& name, int association);
  bool Lattice(const std::vector<Summary>& all, const std::string& name, int association, const int requested[3],
    std::string& problem);
  void Regions(const std::vector<Summary>& all);
  /// vtkNeuralCompressPieceSampling.cxx: every rank's padded region resampled from this rank's blocks and sent to
  /// it; this rank's own from every rank's. The training image and domain mask; false with `problem` when a
  /// resampling of this rank failed (every rank still takes part in every exchange).
  bool SampleRegions(vtkDataObject* local, const std::string& name, int association, std::string& problem);

  // The cached local summary (by the input's stamp).
  uint64_t SummaryStamp = 0;
  bool SummaryValid = false;
  Summary Mine{};
  // What the last Prepare used (changes on any rank make every rank prepare again).
  uint64_t PreparedStamp = 0;
  bool Prepared = false;

  // The lattice and every rank's boxes (point extents in the lattice's index frame; empty: lo > hi).
  int Dims[3] = { 0, 0, 0 };
  double Origin[3] = { 0, 0, 0 };
  double Spacing[3] = { 1, 1, 1 };
  double Upper[3] = { 0, 0, 0 }; ///< the whole input's upper bounds
  std::array<int, 6> WholeExtent{ { 0, -1, 0, -1, 0, -1 } };
  std::array<int, 6> OwnedExtent{ { 0, -1, 0, -1, 0, -1 } };
  std::vector<std::array<int, 6>> OwnedBoxes, PaddedBoxes;
  int Components = 1;

  vtkSmartPointer<vtkImageData> TrainingImage;
  std::shared_ptr<std::vector<uint8_t>> OutsideMask;
  double OwnBytes = 0.0;
  double OwnSamples = 0.0;
  int64_t Filled = 0; ///< samples taken from other ranks' blocks
  int64_t Blocks = 0; ///< this rank's blocks with the array
  std::string Text;
};

} // namespace vtkNeuralCompressInternals

#endif
