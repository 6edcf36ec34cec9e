// Neural Compress under MPI (private header): `mpiexec -n N pvbatch` or a parallel pvserver hands every rank only a
// piece of the input; the network is trained once, on rank 0, over the whole input. Images, other datasets,
// composites and AMR no longer come here: every rank trains a network of its own piece (vtkNeuralCompressPartition.h,
// vtkNeuralCompressDataSetPiece.h), so the image branch below (pieces stitched by extent, StitchImages) is no longer
// reached; sparse VDB voxels and composites of particle sets are gathered (particle sets:
// vtkNeuralCompressParticlePiece.h).
//
// Design (only when the global vtkMultiProcessController has more than one process; with one process -- the GUI,
// pvpython, client-server with one server process, builds without MPI -- nothing here runs and the filter behaves as
// before):
// - RequestUpdateExtent: every rank asks its input for its own piece (piece = rank of N, no ghost levels; for
//   structured inputs the update extent stays the whole extent and a source that can produce sub-extents splits it).
// - RequestData (and, for inputs that are not images, RequestInformation, whose announced extent depends on the
//   whole input's bounds): every rank sends its piece -- reduced to the selected array, the ghost arrays and the
//   global point ids -- to rank 0 through vtkMultiProcessController::Gather of data objects. Rank 0 assembles the
//   whole input: image pieces are stitched by extent into one image of the whole extent (point or cell array,
//   ghost points/cells left out, every point or cell of the whole extent must be covered); any other dataset is the
//   union of the pieces (vtkAppendDataSets with MergePoints: by global point ids when the pieces carry them, else
//   coincident points), a composite keeps its structure with the pieces of each block merged the same way. Rank 0
//   then trains as in serial; its output is the whole image with the network (field data NeuralNetwork etc.).
//   The other ranks never train: their output 0 is an empty image (no points) and their tables are empty.
// - Extents: every rank announces the same WHOLE_EXTENT (the input's, or for a resampled input the one computed
//   from the whole input's sampling dimensions, broadcast by rank 0). ParaView's data information merges the ranks'
//   extents and sums their points, so it reports the whole output exactly once; the Neural Volume representation
//   draws rank 0's image and the empty pieces draw nothing. The pipeline does not re-execute the empty pieces:
//   for requests of several pieces the executive keeps the requested extent as ALL_PIECES_EXTENT of the output.
// - Collectives are reached by every rank on every path: the gather runs when the input changed -- another producer,
//   a newer pipeline MTime upstream (a property of an upstream proxy), another data time step -- or the selected
//   array changed; in ParaView these change on every rank together (every rank holds the same proxies and updates
//   the same pipeline). Executions of rank 0 alone -- the live-source refresh of background training,
//   WaitForTraining or a control, which modify only the rank that trains -- find the input unchanged and gather
//   nothing. (The input data object itself is no such signal: ParaView's vtkPVPostFilter in front of the input
//   regenerates it on every execution of the filter.) Errors (array missing on a piece, pieces that do not cover
//   the whole extent) are reported by rank 0 after the collectives, as vtkErrorMacro, and give the usual empty
//   output.
#ifndef vtkNeuralCompressDistributed_h
#define vtkNeuralCompressDistributed_h

#include "vtkSmartPointer.h"
#include "vtkType.h"

#include <string>

class vtkAlgorithm;
class vtkDataObject;
class vtkInformation;
class vtkInformationVector;
class vtkMultiProcessController;

namespace vtkNeuralCompressInternals
{

/// The global controller when it runs more than one process, else null (serial: nothing distributed).
vtkMultiProcessController* DistributedController();

/// RequestUpdateExtent under MPI: the input's request becomes this rank's piece (no ghost levels).
void RequestLocalPiece(vtkInformation* inInfo);

/// RequestInformation under MPI: the input (`self`'s first connection) brought up to date as this rank's piece
/// (every rank together: the producer may be a collective such as RedistributeDataSet).
void UpdateLocalPiece(vtkAlgorithm* self, vtkInformation* inInfo);

/// While it lives (when `active`), this process runs VTK's filters on its own: the global controller is a
/// one-process one. ParaView's object factory substitutes parallel filters under MPI (vtkResampleToImage becomes
/// vtkPResampleToImage, which reduces over every rank); rank 0 uses them on the whole input while the other ranks do
/// not execute.
class RootOnlyScope
{
public:
  explicit RootOnlyScope(bool active);
  ~RootOnlyScope();

private:
  RootOnlyScope(const RootOnlyScope&) = delete;
  RootOnlyScope& operator=(const RootOnlyScope&) = delete;
  vtkMultiProcessController* Saved = nullptr;
  vtkSmartPointer<vtkMultiProcessController> Single;
};

/// What RequestData does with the gathered input.
enum class DistributedRole
{
  Serial,    ///< one process: the filter's own input, as always
  Root,      ///< rank 0: train on Whole() (read its arrays through WholeVector())
  Satellite, ///< other ranks: output an empty image, train nothing
  Failed     ///< rank 0: the whole input could not be assembled (reported); the usual empty output
};

/// The gathered whole input of one filter and the sampling statistics of a resampled input.
class DistributedInput
{
public:
  DistributedInput();
  ~DistributedInput();

  /// RequestData: gathers the pieces (collective, when this rank's input or the selected array changed) and says
  /// what this rank does. `self` is the filter (its selected array), `local` this rank's input, `inInfo` its
  /// pipeline information.
  DistributedRole Gather(vtkAlgorithm* self, vtkDataObject* local, vtkInformation* inInfo);

  /// The whole input on rank 0 after Gather returned Root.
  vtkDataObject* Whole() const { return this->WholeObject; }
  /// An input information vector holding Whole(), for vtkAlgorithm::GetInputArrayToProcess.
  vtkInformationVector** WholeVector() { return this->WholeVectors; }

  /// RequestInformation of an input that is not an image, under MPI: the sampling dimensions of the whole input
  /// (`requested`, or automatic from the whole input's bounds and samples as in serial), the output extent (with
  /// `outputResolution`) set as WHOLE_EXTENT on `outInfo` (removed when the input cannot be resampled) and
  /// `announced` (0 0 0 when none). Brings the input up to date and gathers it when the whole input's statistics for
  /// the selected array are not known yet (every rank gets here together: the first update, a new array).
  void Announce(vtkAlgorithm* self, vtkInformation* inInfo, vtkInformation* outInfo, const int requested[3],
    const int outputResolution[3], int announced[3]);

private:
  DistributedInput(const DistributedInput&) = delete;
  DistributedInput& operator=(const DistributedInput&) = delete;

  /// The collective step: every rank's piece to rank 0, which assembles Whole() and broadcasts the sampling
  /// statistics of a resampled input.
  void Sync(vtkAlgorithm* self, vtkDataObject* local, vtkInformation* inInfo, const std::string& name,
    int association);

  /// What decides a new gather (the same on every rank: see the header comment).
  struct Signature
  {
    vtkAlgorithm* Producer = nullptr;
    int Port = -1;
    vtkMTimeType PipelineMTime = 0;
    bool HasTime = false;
    double Time = 0.0;
    bool operator==(const Signature& o) const
    {
      return this->Producer == o.Producer && this->Port == o.Port && this->PipelineMTime == o.PipelineMTime &&
        this->HasTime == o.HasTime && (!this->HasTime || this->Time == o.Time);
    }
  };
  static Signature InputSignature(vtkAlgorithm* self, vtkDataObject* local);

  // What the last gather saw on this rank.
  bool Synced = false;
  Signature Input;
  std::string Name;
  int Association = -1;

  // Rank 0: the whole input (null when it could not be assembled; Problem says why).
  vtkSmartPointer<vtkDataObject> WholeObject;
  std::string Problem;
  vtkSmartPointer<vtkInformationVector> WholeInfo;
  vtkInformationVector* WholeVectors[1];

  // Every rank: the automatic sampling dimensions of the whole input for Name/Association (resampled inputs).
  bool StatsValid = false;
  bool StatsOk = false;
  int AutoDims[3] = { 0, 0, 0 };
  std::string StatsProblem;
};

} // namespace vtkNeuralCompressInternals

#endif
