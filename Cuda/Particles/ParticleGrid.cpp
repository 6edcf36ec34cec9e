#include "ParticleGrid.h"

#include "Core/Error.h"

#include <algorithm>
#include <string>

namespace nv
{

ParticleGrid::ParticleGrid(std::vector<ParticleRecord> records, const double lo[3], const double hi[3],
  double cellSize, int64_t maxCells)
{
  NV_CHECK(!records.empty(), "a particle grid needs at least one particle");
  NV_CHECK(maxCells >= 1 && maxCells <= (int64_t(1) << 30), "at most 2^30 cells");
  double extent[3];
  for (int a = 0; a < 3; ++a)
  {
    this->Origin[a] = lo[a];
    extent[a] = std::max(0.0, hi[a] - lo[a]);
  }
  double edge = cellSize > 0.0 && std::isfinite(cellSize) ? cellSize
                                                          : std::max({ extent[0], extent[1], extent[2], 1e-30 });
  auto cellsAt = [&extent](double e) {
    double n = 1.0;
    for (int a = 0; a < 3; ++a)
      n *= std::floor(extent[a] / e) + 1.0;
    return n;
  };
  while (cellsAt(edge) > double(maxCells))
    edge *= 1.25; // coarser cells until the grid fits its bound
  this->CellEdge = edge;
  for (int a = 0; a < 3; ++a)
    this->Dims[a] = int(std::floor(extent[a] / edge)) + 1;
  const int64_t cells = this->cellCount();
  auto cellOf = [this](const ParticleRecord& r) {
    const float p[3] = { r.x, r.y, r.z };
    int64_t index = 0, stride = 1;
    for (int a = 0; a < 3; ++a)
    {
      int i = int(std::floor(double(p[a]) / this->CellEdge));
      i = std::min(std::max(i, 0), this->Dims[a] - 1);
      index += int64_t(i) * stride;
      stride *= this->Dims[a];
    }
    return index;
  };
  // Counting sort by cell.
  this->Start.assign(size_t(cells + 1), 0);
  for (const ParticleRecord& r : records)
    ++this->Start[size_t(cellOf(r) + 1)];
  for (int64_t c = 0; c < cells; ++c)
    this->Start[size_t(c + 1)] += this->Start[size_t(c)];
  std::vector<int64_t> next(this->Start.begin(), this->Start.end() - 1);
  this->Records.resize(records.size());
  for (const ParticleRecord& r : records)
    this->Records[size_t(next[size_t(cellOf(r))]++)] = r;
}

int64_t ParticleGrid::bytes() const
{
  return int64_t(this->Records.size() * sizeof(ParticleRecord) + this->Start.size() * sizeof(int64_t));
}

SpacingGrid::SpacingGrid(int64_t count, const double extent[3])
{
  const double largest = std::max({ extent[0], extent[1], extent[2] });
  if (count <= 0 || !(largest > 0.0))
    return;
  double measure = 1.0;
  for (int a = 0; a < 3; ++a)
    if (extent[a] > 1e-6 * largest)
    {
      ++this->Active;
      measure *= extent[a];
    }
  const double cells = std::min(std::max(double(count) / 8.0, 1.0), double(1 << 24));
  this->Edge = std::pow(measure / cells, 1.0 / this->Active);
  for (int a = 0; a < 3; ++a)
    this->Dims[a] = extent[a] > 1e-6 * largest ? int(std::min(std::floor(extent[a] / this->Edge) + 1.0, 1e6)) : 1;
  NV_CHECK(this->cells() > 0 && this->cells() <= (int64_t(1) << 26),
    "the spacing grid has " + std::to_string(this->cells()) + " cells");
}

int64_t SpacingGrid::cellOf(const float p[3]) const
{
  int64_t index = 0, stride = 1;
  for (int a = 0; a < 3; ++a)
  {
    const int i = std::min(std::max(int(std::floor(double(p[a]) / this->Edge)), 0), this->Dims[a] - 1);
    index += int64_t(i) * stride;
    stride *= this->Dims[a];
  }
  return index;
}

double SpacingGrid::spacing(int64_t occupied, int64_t count) const
{
  if (!(this->Edge > 0.0) || count <= 0)
    return 0.0;
  return std::pow(double(occupied) * std::pow(this->Edge, this->Active) / double(count), 1.0 / this->Active);
}

double meanParticleSpacing(const std::vector<ParticleRecord>& records, const double extent[3])
{
  const int64_t n = int64_t(records.size());
  const SpacingGrid grid(n, extent);
  if (!(grid.Edge > 0.0))
    return 0.0;
  std::vector<uint8_t> occupied(size_t(grid.cells()), 0);
  int64_t count = 0;
  for (const ParticleRecord& r : records)
  {
    const float p[3] = { r.x, r.y, r.z };
    const int64_t index = grid.cellOf(p);
    count += occupied[size_t(index)] ? 0 : 1;
    occupied[size_t(index)] = 1;
  }
  return grid.spacing(count, n);
}

} // namespace nv
