// Neural Compress under MPI with one network per rank (private header; vtkNeuralCompressPartition.h): the coarse grid
// of the whole field that every rank's Neural Volume needs for shadows and path tracing across pieces
// (nv::RenderRequest::surroundings; the engine's RaySurroundings.h).
//
// A rank's network covers its padded piece only, and its rays are clipped to its own piece; light reaching a sample
// crosses the other pieces too. So every execution ends, after the global figures, with this collective: the ranks
// agree on one lattice of about kSurroundingsSamples points over the union of their pieces' bounds (NeuralPieceBounds;
// anisotropic like it), each rank decodes its own network at the lattice points its piece owns (a boundary plane
// shared by two pieces belongs to the upper one, the whole's last plane to the last piece, as for the global
// figures), and one all-reduce (the maximum at each point: its owner's value, kNoValue from the others) gives every
// rank the whole lattice (NaN where no rank had a value). The output carries it as field data NeuralSurroundings (float values, x fastest),
// NeuralSurroundingsDimensions and NeuralSurroundingsBounds (the image's index-aligned frame, as NeuralPieceBounds);
// the Neural Volume passes it to the engine for the shading modes with secondary rays. No rank holds more than its
// piece and this grid (O(model)). It is built again only when some rank's network changed (a new version while it
// trains in the background, a new training); the decision itself is collective.
#ifndef vtkNeuralCompressSurroundings_h
#define vtkNeuralCompressSurroundings_h

#include "vtkSmartPointer.h" // for the arrays kept between executions

#include <cstdint>
#include <string>
#include <vector>

class vtkDoubleArray;
class vtkFloatArray;
class vtkImageData;
class vtkIntArray;

namespace nv
{
class NetworkSession;
}

namespace vtkNeuralCompressInternals
{

/// Points of the coarse lattice over the whole field (about 80^3: 2 MiB of floats on every rank).
constexpr int64_t kSurroundingsSamples = 80 * 80 * 80;
/// A lattice point this rank has no value for, before the reduction (the maximum over the ranks keeps the owner's).
constexpr float kNoValue = -3.402823466e+38f;

/// Samples per axis of a lattice of about `budget` points over `bounds` (xmin xmax ...), each axis's count
/// proportional to its length (at least 2; a flat axis gets 2).
void SurroundingsDimensions(const double bounds[6], int64_t budget, int dims[3]);

/// The lattice indices lo..hi (inclusive) along one axis of n samples over [wholeLo, wholeHi] that a piece [pieceLo,
/// pieceHi] owns: from its lower plane on, below its upper plane unless that is the whole's upper plane. lo > hi: none.
void OwnedLatticeRange(double wholeLo, double wholeHi, int n, double pieceLo, double pieceHi, int& lo, int& hi);

/// One filter's surroundings grid, kept between executions.
class Surroundings
{
public:
  /// Collective: every rank calls it once per execution, in the same order as the other collectives. `output` is this
  /// rank's output (its network and NeuralPieceBounds; an empty or failed output takes part without a network). On
  /// success the output gets the three field data arrays; an error is reported by vtkErrorMacro-like text in
  /// `problem` and leaves the output without them.
  void Update(vtkImageData* output, std::string& problem);

private:
  /// The union of every rank's piece bounds (a collective); false when no rank has a piece.
  static bool WholeBounds(const double* own, double whole[6]);
  /// This rank's values at the points of the lattice of `dims` points over `whole` that it owns and where its
  /// network has a value (values[i]; the others stay as they are: kNoValue).
  static void DecodeOwnPoints(nv::NetworkSession& session, const double whole[6], const int dims[3],
    const double own[6], std::vector<float>& values);
  /// The reduced values kept (kNoValue, a point no rank had a value for, becomes NaN).
  void Keep(const double whole[6], const int dims[3], vtkFloatArray* values);

  uint64_t Signature = 0;   ///< this rank's network and bounds at the last build
  double Bounds[6] = { 0, -1, 0, -1, 0, -1 };
  int Dims[3] = { 0, 0, 0 };
  vtkSmartPointer<vtkFloatArray> Values;      ///< the whole lattice (NaN: no rank had a value)
  vtkSmartPointer<vtkIntArray> Dimensions;    ///< Dims, as field data
  vtkSmartPointer<vtkDoubleArray> BoundsArray; ///< Bounds, as field data
};

} // namespace vtkNeuralCompressInternals

#endif
