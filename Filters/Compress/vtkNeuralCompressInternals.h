// Private to NeuralVolume::Filters: the engine-facing half of vtkNeuralCompress. Keeps the engine
// headers out of the wrapped public header (the way vtkONNXInference hides its runtime).
#ifndef vtkNeuralCompressInternals_h
#define vtkNeuralCompressInternals_h

#include "Core/Engine.h"
#include "Core/Model.h"
#include "Core/NetworkSession.h"
#include "Core/PsnrProbe.h"
#include "Core/RunStatus.h"
#include "Core/TrainingData.h"
#include "Core/TrainingRun.h"
#include "Core/Volume.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

class vtkDataArray;

namespace vtkNeuralCompressInternals
{

// The engine's training run (Core/TrainingRun.h) and the types around it, which the filter's files name unqualified.
using nv::isSettled;
using nv::LogRow;
using nv::PsnrProbe;
using nv::RunLimits;
using nv::RunState;
using nv::runStateName;
using nv::RunStatus;
using nv::SourceField;
using nv::TrainingData;
using nv::TrainingRun;

/// Fill `field` from `array` (nTuples must equal dims[0]*dims[1]*dims[2]). Returns false and sets
/// `error` when the array cannot be represented.
bool MakeSourceField(vtkDataArray* array, int vectorMode, int component, const int64_t dims[3],
  SourceField& field, std::string& error);

/// Geometry of the decoded output for an input of extent/origin/spacing and a requested
/// resolution (samples per axis; 0 = the source's). For a point array the samples are the
/// output's points; for a cell array they are its cells.
struct OutputGeometry
{
  int Extent[6];
  double Origin[3];
  double Spacing[3];
  int SourceDims[3];  ///< samples per axis of the trained field (points or cells)
  int DecodedDims[3]; ///< samples per axis of the decoded output
  bool OnSourceGrid;  ///< decoded samples coincide with the source samples
  int CapSamples = 0; ///< the finest level's samples per axis when it lowered OutputResolution (0: it did not)
  /// The samples are Origin + index x Spacing over Extent (cell centres: + 0.5) in world space, mapped into the
  /// network's source bounds: a rank's part of the whole output lattice under MPI (PieceOfWholeGeometry). False: the
  /// decoded dimensions span the network's own source bounds (or its source grid).
  bool WorldSamples = false;
};
/// The output of a source extent decoded at `res` samples per axis (0 on an axis: the source's own). An axis asked
/// finer than what the network resolves (nv::kDecodeOversampling x its finest hash-grid level, `finestResolution`
/// samples per axis; 0: the filter's default, twice the largest source dimension and at least `baseResolution`) and
/// than the source's own samples is decoded at the larger of the two (CapSamples says so). finestResolution < 0: no cap.
OutputGeometry ComputeGeometry(const int ext[6], const double origin[3], const double spacing[3], bool cells,
  const int res[3], int finestResolution = -1, int baseResolution = 0);

/// MPI: a rank's part of the whole output lattice `whole` (ComputeGeometry of the whole extent, the same on every
/// rank). `pieceExtent` is the rank's padded piece and `owned` the extent it owns, in the input's index frame of
/// `origin`, `spacing`. An axis the whole output keeps on the source lattice stays the padded piece's (the filter crops
/// it to the owned extent: vtkNeuralCompressPartition.h). On a resampled axis the rank decodes the lattice samples it
/// owns (a point or cell centre on a shared boundary belongs to the upper piece) and, for points, the next lattice
/// point too, so that neighbouring pieces share a point layer as ParaView's pieces of an image do; such a geometry is
/// decoded at world positions (WorldSamples).
OutputGeometry PieceOfWholeGeometry(const OutputGeometry& whole, const int pieceExtent[6], const int owned[6],
  const int wholeExtent[6], const double origin[3], const double spacing[3], bool cells);

} // namespace vtkNeuralCompressInternals

#endif
