// NeuralVolume engine: the point locator of a particle field (ParticleField.h) -- a uniform grid of cells over the
// particles' box, the particles sorted by cell (a counting sort, one index array of cell starts). A query visits the
// particles of the cells within a reach of a point; the grid holds each particle once, never a splat of it.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace nv
{

/// One particle as the reconstruction reads it: position relative to the grid's origin, support radius R,
/// value (or mass) and 1 / R^3.
struct ParticleRecord
{
  float x, y, z, radius, value, invRadius3;
};

class ParticleGrid
{
public:
  /// Sorts `records` (positions relative to `lo`, inside [0, hi - lo]) into cubic cells of edge at least `cellSize`,
  /// at most `maxCells` of them (the edge grows to stay within). Throws nv::Error for an empty set.
  ParticleGrid(std::vector<ParticleRecord> records, const double lo[3], const double hi[3], double cellSize,
    int64_t maxCells);

  /// Calls visit(record) for every particle of the cells that the cube of half-edge `reach` around world point x
  /// touches (a superset of the particles within `reach`).
  template <class Visit>
  void forEachNear(const double x[3], double reach, Visit&& visit) const
  {
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a)
    {
      const double u = x[a] - this->Origin[a];
      const double l = std::floor((u - reach) / this->CellEdge), h = std::floor((u + reach) / this->CellEdge);
      if (h < 0.0 || l > double(this->Dims[a] - 1) || !(l == l) || !(h == h))
        return; // outside the grid (or NaN)
      lo[a] = l < 0.0 ? 0 : int(l);
      hi[a] = h > double(this->Dims[a] - 1) ? this->Dims[a] - 1 : int(h);
    }
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
      {
        const int64_t row = (int64_t(k) * this->Dims[1] + j) * this->Dims[0];
        const int64_t first = this->Start[size_t(row + lo[0])], last = this->Start[size_t(row + hi[0] + 1)];
        for (int64_t p = first; p < last; ++p)
          visit(this->Records[size_t(p)]);
      }
  }

  /// The cell of world point x (clamped to the grid; 0 for NaN): for ordering queries by place.
  int64_t cellIndex(const double x[3]) const
  {
    int64_t index = 0, stride = 1;
    for (int a = 0; a < 3; ++a)
    {
      const double u = std::floor((x[a] - this->Origin[a]) / this->CellEdge);
      const int i = u >= 0.0 ? (u < double(this->Dims[a]) ? int(u) : this->Dims[a] - 1) : 0;
      index += int64_t(i) * stride;
      stride *= this->Dims[a];
    }
    return index;
  }

  int64_t size() const { return int64_t(this->Records.size()); }
  const double* origin() const { return this->Origin; }
  double cellEdge() const { return this->CellEdge; }
  int64_t cellCount() const { return int64_t(this->Dims[0]) * this->Dims[1] * this->Dims[2]; }
  /// Bytes the grid holds (records and cell starts).
  int64_t bytes() const;

private:
  double Origin[3] = { 0, 0, 0 };
  double CellEdge = 1.0;
  int Dims[3] = { 1, 1, 1 };
  std::vector<int64_t> Start; ///< cellCount + 1 offsets into Records, x fastest
  std::vector<ParticleRecord> Records;
};

/// The occupancy grid of meanParticleSpacing for `count` particles over a box [0, extent]: about 8 particles per
/// cell (at most 2^24 cells) over the axes that are not flat. Split from it so that ranks of a distributed set can
/// mark their own particles' cells in the whole set's grid and count the occupied cells together.
struct SpacingGrid
{
  double Edge = 0.0; ///< 0: no particle, or all at one point
  int Dims[3] = { 1, 1, 1 };
  int Active = 0; ///< axes that are not flat
  SpacingGrid(int64_t count, const double extent[3]);
  /// The cell of a position in the records' frame (clamped to the grid), x fastest.
  int64_t cellOf(const float p[3]) const;
  int64_t cells() const { return int64_t(this->Dims[0]) * this->Dims[1] * this->Dims[2]; }
  /// The spacing d with count * d^k = the measure of `occupied` cells.
  double spacing(int64_t occupied, int64_t count) const;
};

/// The mean particle spacing of `count` positions (relative to `lo`, in a box of `extent`): the d with
/// count * d^k = the measure of the cells that hold a particle, in a grid of about 8 particles per cell over the k
/// axes that are not flat. 0 when every particle lies at one point.
double meanParticleSpacing(const std::vector<ParticleRecord>& records, const double extent[3]);

} // namespace nv
