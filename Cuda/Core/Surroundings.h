// NeuralVolume engine: a request's surroundings grid (RenderRequest::surroundings) made ready for the ray machine
// (RaySurroundings.h) on the host, for both backends: checked, normalised to its own value range once per grid, placed
// in network coordinates and given the transfer function's map and majorant every render.
#pragma once

#include "RayState.h"
#include "Render.h"

#include <cstdint>
#include <memory>
#include <ostream>
#include <vector>

namespace nv
{

struct RenderSetup;

/// True when the request's shading mode sends secondary rays (RayMarchShadows, PathTrace, PathTraceNee) and it has
/// surroundings: only then do they change the picture.
bool usesSurroundings(const RenderRequest& request);

/// Appends "...; " to `problems` for each way the surroundings cannot be used (dimensions < 2 or too many samples,
/// values of another count, a box that is not finite or empty); nothing when the request has none.
void checkSurroundings(const RenderRequest& request, std::ostream& problems);

/// The world length of the surroundings box's edges, summed (b: the inverse of the volume transform's linear part,
/// row-major 3 x 3), for the bound on a ray's steps through it.
double surroundingsEdgeLength(const SurroundingsGrid& grid, const double b[9]);

/// The largest extinction (per world unit) of the table `table` (tfSize entries of r, g, b, extinction) over entry
/// coordinates [c0, c1] (clamped to the table), linear between entries.
float tableMajorant(const float* table, int tfSize, float c0, float c1);

/// One renderer's normalised copy of the last surroundings grid it was given (the request's grid is immutable: the
/// same object is normalised once).
class SurroundingsCache
{
public:
  /// P's surroundings for this request (P.surround null when !usesSurroundings(request)): P.surround points at
  /// values() in host memory (the GPU renderer points it at its device copy). Returns true when values() changed.
  bool prepare(const RenderRequest& request, const RenderSetup& setup, ray::Params& P);
  /// The grid's values normalised to their finite range, NaN where there is no data.
  const std::vector<float>& values() const { return Values; }

private:
  std::shared_ptr<const SurroundingsGrid> Grid;
  std::vector<float> Values;
  double Range[2] = { 0.0, 0.0 }; ///< the grid's finite values' range (lo > hi: none)
};

} // namespace nv
