// Neural Compress under MPI with a particle set (private header): one network per rank, no gather, and no particle
// leaves its rank.
//
// Design (when every rank's input is a particle set -- poly data or an unstructured grid of vertices, an empty piece
// counting as one -- under a vtkMultiProcessController of more than one process):
// - The serial lattice: one all-gather of a few numbers a rank (its particles' boxes and counts, bytes, largest
//   radius) gives every rank the serial run's image: the box of every particle used, at SamplingDimensions or the
//   serial automatic dimensions of the summed count (vtkNeuralCompressParticles.h).
// - The automatic radius is the serial one: the serial mean spacing counts the occupied cells of one grid over the
//   whole set's box (nv::SpacingGrid); each rank marks its own particles' cells in its box of that grid, the ranks
//   whose boxes overlap tell the higher rank which shared cells they hold (a cell is counted by the lowest rank that
//   holds it), and one all-reduce sums the counts. Each rank then builds its own particles' locator with that radius.
// - Regions: the grid path's k-d split of the ranks' particle boxes, snapped to lattice planes
//   (LatticeRegions, vtkNeuralCompressDataSetPiece.h), each grown by kPieceGhostLayers.
// - The reconstruction near a cut needs particles of both sides. The kernel sums are additive (Interpolate:
//   sum f W / sum W; Density: sum f W), so a rank evaluates its own particles' sums (nv::ParticleField::kernelSums,
//   in the data's units) at the lattice points of every rank's padded region that its particles reach (their box
//   grown by the largest radius and one lattice layer) and sends them to that rank, which adds them to its own: only
//   sums over the overlap travel, the value is the serial one up to the order of the summation, and no rank receives
//   another's particles (halo particles would travel as well, and each rank would rebuild a locator of them).
// - Then the grid path (vtkNeuralCompress::ExecuteGridPiece): the padded image is trained (from the lattice, not a
//   Probe bank), the output cropped to the owned region, ordered compositing, the global figures all-reduced over
//   the lattice (serial particle runs measure at the particles).
#ifndef vtkNeuralCompressParticlePiece_h
#define vtkNeuralCompressParticlePiece_h

#include "vtkNeuralCompressParticles.h"

#include "vtkImageData.h" // for vtkSmartPointer<vtkImageData>
#include "vtkSmartPointer.h"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

class vtkDataObject;

namespace nv
{
class ParticleField;
}

namespace vtkNeuralCompressInternals
{
/// True under MPI when every rank's input is a particle set or an empty point set, and one rank at least holds
/// particles. A collective: every rank calls it in the same pass.
bool PerRankParticles(vtkDataObject* local);

/// A rank's piece of a particle set: the lattice, its region and the padded image of the reconstruction there.
class ParticlePiece
{
public:
  ParticlePiece();
  ~ParticlePiece();

  /// RequestInformation (a collective): the whole lattice's dimensions; false with `problem` (the same on every
  /// rank) when no rank has the array or usable particles.
  bool Resolve(vtkDataObject* local, const std::string& name, int association, const int requested[3],
    const ParticleSettings& settings, int dims[3], std::string& problem);

  /// RequestData (a collective): the lattice, the radius, the regions and the exchange of kernel sums; false with
  /// `problem` when any rank failed (the same decision on every rank). Reuses the last piece while no rank's input,
  /// array, settings or dimensions changed.
  bool Prepare(vtkDataObject* local, const std::string& name, int association, const int requested[3],
    const ParticleSettings& settings, std::string& problem);

  bool HasPiece() const { return this->TrainingImage != nullptr; }
  /// The padded image to train on (point array named as the input's, NaN outside every particle's support).
  vtkImageData* Training() const { return this->TrainingImage; }
  const int* Owned() const { return this->OwnedExtent.data(); }
  const int* Whole() const { return this->WholeExtent.data(); }
  std::shared_ptr<std::vector<uint8_t>> Outside() const { return this->OutsideMask; }
  /// Bytes of this rank's particles (positions and the scalar): its share of the compression ratio.
  double SourceBytes() const { return this->OwnBytes; }
  /// This rank's particles used by the reconstruction.
  double SourceSamples() const { return this->OwnParticles; }
  /// The support radius every rank used (constant radius: automatic or ParticleRadius; 0 for a radius array).
  double Radius() const { return this->CommonRadius; }
  const std::string& Description() const { return this->Text; }
  /// The reconstruction over the owned extent: the samples inside the support, the sum of their values and of their
  /// squares (field data NeuralPieceTrainingSums, which the MPI test compares with the serial reconstruction).
  std::array<double, 3> OwnedSums() const;

  /// Every rank's summary: see the .cxx.
  using Summary = std::array<double, 19>;

private:
  bool Summarize(vtkDataObject* local, const std::string& name, const ParticleSettings& settings,
    std::vector<Summary>& all, std::string& problem);
  bool Lattice(const std::vector<Summary>& all, const int requested[3], std::string& problem);
  double AutomaticRadius(const std::vector<Summary>& all);
  bool BuildField(const ParticleSettings& settings, std::string& problem);
  void Regions(const std::vector<Summary>& all);
  void AddKernelSums(std::vector<double>& weighted, std::vector<double>& weights);
  void MakeTrainingImage(const std::string& name, int mode, const std::vector<double>& weighted,
    const std::vector<double>& weights);

  // The local particles (positions, values, radii) until the field is built, and their summary.
  ParticleArrays Arrays;
  bool ArraysValid = false;
  uint64_t SummaryStamp = 0;
  Summary Mine{};
  uint64_t PreparedStamp = 0;
  bool Prepared = false;

  int Dims[3] = { 0, 0, 0 };
  double Origin[3] = { 0, 0, 0 };
  double Spacing[3] = { 1, 1, 1 };
  std::array<int, 6> WholeExtent{ { 0, -1, 0, -1, 0, -1 } };
  std::array<int, 6> OwnedExtent{ { 0, -1, 0, -1, 0, -1 } };
  std::vector<std::array<int, 6>> PaddedBoxes, ReachBoxes;
  double CommonRadius = 0.0;
  std::shared_ptr<const nv::ParticleField> Field;

  vtkSmartPointer<vtkImageData> TrainingImage;
  std::shared_ptr<std::vector<uint8_t>> OutsideMask;
  double OwnBytes = 0.0;
  double OwnParticles = 0.0;
  int64_t FromNeighbours = 0; ///< lattice points whose sums other ranks added
  std::string Text;
};

} // namespace vtkNeuralCompressInternals

#endif
