// Neural Compress under MPI with an image input (private header): one network per rank, no gather.
//
// Design (only when the global vtkMultiProcessController has more than one process and the input is a vtkImageData;
// other inputs still go through vtkNeuralCompressDistributed.h's gather to rank 0):
// - RequestUpdateExtent: every rank asks its input for its own piece of the whole extent (vtkExtentTranslator's
//   block split of the cells, rank of N: neighbouring pieces share one plane of points) grown by kPieceGhostLayers
//   layers on every side that is not the whole extent's boundary. The request is an explicit UPDATE_EXTENT (piece 0
//   of 1), so any image pipeline -- sources that split by piece and filters that pass extents up -- produces it.
// - RequestData: every rank trains its own network on that padded piece as a serial run would (no communication
//   while training; the engine sees an ordinary image), then crops its output image to its own piece ("owned"
//   extent, no ghost layers) and records the piece's bounds as field data NeuralPieceBounds. The Neural Volume
//   representation clips its rays to those bounds (nv::RenderRequest::clipBox) and ParaView composites the ranks'
//   pictures in visibility order from the pieces' bounds (vtkImageVolumeRepresentation declares them with
//   USE_BOUNDS_FOR_REDISTRIBUTION), so the picture is seamless: the ghost layers make each network continuous
//   across its piece's faces and no sample is drawn twice.
// - Global figures (vtkNeuralCompressGlobalFigures.h): every execution ends with one all-reduce of a few numbers;
//   NeuralPSNR, NeuralMaxError, NeuralCompressionRatio and NeuralModelBytes are then the whole field's, the same on
//   every rank.
#ifndef vtkNeuralCompressPartition_h
#define vtkNeuralCompressPartition_h

#include "vtkImageData.h" // for vtkSmartPointer<vtkImageData>
#include "vtkSmartPointer.h"

class vtkDataObject;
class vtkInformation;

namespace vtkNeuralCompressInternals
{
/// Ghost layers (samples) around each rank's piece that its network is trained on as well: the network's values
/// near the piece's faces are fitted on both sides of them, so neighbouring networks agree there.
constexpr int kPieceGhostLayers = 3;

/// The RMI tag by which rank 0 asks every rank whether its background run needs an update (ParaView's live-source
/// poll runs on rank 0 alone; vtkNeuralCompressPiece.cxx).
constexpr int kLiveUpdateRmiTag = 0x4E564C55; // "NVLU"

/// True under MPI (more than one process) for an image input: one network per rank (this header).
bool PerRankNetworks(vtkDataObject* input);

/// The ranks running on this rank's host and this rank's index among them (its local rank, by global rank).
struct HostRanks
{
  int Count = 1;
  int Index = 0;
};

/// This rank's place on its host (1 rank, index 0 without MPI): a collective the first time (every rank calls it in
/// the same execution), then cached. Threads = 0 (automatic) under MPI shares the host's cores among the ranks; the
/// first call also chooses this process's CUDA device from the index (vtkNeuralCudaDevice.h).
HostRanks RanksOnThisHost();

/// The ranks on this host as RanksOnThisHost found them (1 before it ran, and without MPI); never a collective. The
/// automatic MemoryBudget of an out-of-core piece shares the host's memory among them (vtkNeuralOutOfCoreInput.h).
int KnownRanksOnThisHost();

/// A rank's piece of an image input: the extent it owns and the padded image its network trains on.
class ImagePiece
{
public:
  /// RequestUpdateExtent: the input's request becomes this rank's padded piece (see the header comment).
  static void RequestPaddedPiece(vtkInformation* inInfo);

  /// RequestData: this rank's piece of `local` (the image its input produced) within `wholeExtent`; false when the
  /// rank holds none of it (an empty piece: it trains nothing and contributes nothing to the figures).
  bool Select(vtkImageData* local, const int wholeExtent[6]);

  /// RequestData of a dataset or composite (vtkNeuralCompressDataSetPiece.h): the padded image resampled for this rank,
  /// the point extent it owns and the whole lattice's, all in the image's index frame.
  void Adopt(vtkImageData* training, const int owned[6], const int wholeExtent[6]);

  /// The padded image to train on (the local image itself when it is no larger than the padded piece).
  vtkImageData* Training() const { return this->TrainingImage; }
  /// This rank's own point extent (no ghost layers) and the whole extent.
  const int* Owned() const { return this->OwnedExtent; }
  const int* Whole() const { return this->WholeExtent; }

  /// The output image cropped to the owned piece on the axes it samples on the input's lattice (an axis that
  /// OutputResolution resampled holds the piece's part of the whole output lattice already: PieceOfWholeGeometry),
  /// with field data NeuralPieceBounds (xmin xmax ymin ymax zmin zmax of the piece in the image's index-aligned frame).
  void CropOutput(vtkImageData* output) const;

private:
  vtkSmartPointer<vtkImageData> TrainingImage;
  int OwnedExtent[6] = { 0, -1, 0, -1, 0, -1 };
  int WholeExtent[6] = { 0, -1, 0, -1, 0, -1 };
};

} // namespace vtkNeuralCompressInternals

#endif
