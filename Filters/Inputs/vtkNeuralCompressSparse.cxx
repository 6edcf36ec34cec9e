#include "vtkNeuralCompressSparse.h"
#include "vtkNeuralCompressJob.h"

#include "Core/HashGridMath.h"
#include "Core/Macrocells.h"

#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIntArray.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace vtkNeuralCompressInternals
{

bool IsSparseVoxels(vtkDataObject* input)
{
  auto* pd = vtkPolyData::SafeDownCast(input);
  return pd && pd->GetFieldData() && pd->GetFieldData()->GetAbstractArray("VDBIndexBox");
}

std::string SparseScalarsName(vtkDataObject* input)
{
  auto* pd = vtkPolyData::SafeDownCast(input);
  vtkDataArray* s = pd ? pd->GetPointData()->GetScalars() : nullptr;
  return s && s->GetName() ? s->GetName() : "";
}

bool ReadSparseVoxels(vtkDataObject* input, const std::string& name, SparseVoxels& v, std::string& problem)
{
  auto* pd = vtkPolyData::SafeDownCast(input);
  vtkFieldData* fd = pd ? pd->GetFieldData() : nullptr;
  auto* box = fd ? vtkIntArray::SafeDownCast(fd->GetAbstractArray("VDBIndexBox")) : nullptr;
  auto* map = fd ? vtkDoubleArray::SafeDownCast(fd->GetAbstractArray("VDBIndexToWorld")) : nullptr;
  auto* bg = fd ? vtkDoubleArray::SafeDownCast(fd->GetAbstractArray("VDBBackground")) : nullptr;
  if (!box || box->GetNumberOfValues() != 6 || !map || map->GetNumberOfValues() != 16 || !bg ||
    bg->GetNumberOfValues() != 1)
  {
    problem = "the sparse voxels lack the OpenVDB reader's VDBIndexBox / VDBIndexToWorld / VDBBackground field data";
    return false;
  }
  v.Values = pd->GetPointData()->GetArray(name.c_str());
  v.Coords = vtkIntArray::SafeDownCast(pd->GetPointData()->GetArray("VDBCoordinate"));
  const vtkIdType n = pd->GetNumberOfPoints();
  if (!v.Values || !v.Coords || v.Coords->GetNumberOfComponents() != 3 || v.Values->GetNumberOfTuples() != n ||
    v.Coords->GetNumberOfTuples() != n)
  {
    problem = "the sparse voxels have no point array '" + name + "' with a VDBCoordinate for each voxel";
    return false;
  }
  if (n == 0)
  {
    problem = "the grid has no active voxel";
    return false;
  }
  double voxels = 1.0;
  for (int a = 0; a < 3; ++a)
  {
    v.BoxMin[a] = box->GetValue(2 * a);
    v.Dims[a] = box->GetValue(2 * a + 1) - box->GetValue(2 * a) + 1;
    if (v.Dims[a] < 1)
    {
      problem = "the grid's index box is empty";
      return false;
    }
    voxels *= v.Dims[a];
  }
  if (voxels > double(int64_t(1) << 40))
  {
    problem = "the grid's index box holds more than 2^40 voxels";
    return false;
  }
  // world = M (i, j, k, 1), M row-major: column a of its 3x3 part is the index axis a in world units.
  for (int a = 0; a < 3; ++a)
  {
    const double c[3] = { map->GetValue(a), map->GetValue(4 + a), map->GetValue(8 + a) };
    const double len = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    if (!(len > 0.0) || !std::isfinite(len))
    {
      problem = "the grid's index-to-world transform is singular or not finite";
      return false;
    }
    v.Spacing[a] = len;
    for (int r = 0; r < 3; ++r)
      v.Direction[3 * r + a] = c[r] / len;
  }
  for (int r = 0; r < 3; ++r)
  {
    v.Origin[r] = map->GetValue(4 * r + 3);
    for (int a = 0; a < 3; ++a)
      v.Origin[r] += map->GetValue(4 * r + a) * v.BoxMin[a];
  }
  v.Background = bg->GetValue(0);
  return true;
}

namespace
{
/// The position of voxel `i` of `dim` along an axis, normalised to the box ([0,1]; 0.5 on a flat axis).
float UnitPosition(int64_t i, int64_t dim)
{
  return dim > 1 ? float(double(i) / double(dim - 1)) : 0.5f;
}

/// Every active voxel goes to the bank (its scalar: magnitude for vectorMode 0, else `component`) and its index to
/// `active`; false with `problem` set for a voxel outside the box or listed twice.
bool BankActiveVoxels(const SparseVoxels& v, int vectorMode, int component, SparseBank& bank,
  std::unordered_set<int64_t>& active, std::string& problem)
{
  const int64_t nx = v.Dims[0], ny = v.Dims[1], nz = v.Dims[2];
  const int64_t n = v.Values->GetNumberOfTuples();
  const int nc = v.Values->GetNumberOfComponents();
  const int comp = std::min(std::max(component, 0), nc - 1);
  active.reserve(size_t(n));
  bank.Xyz.reserve(size_t(3 * n));
  bank.Values.reserve(size_t(n));
  const int* ijk = v.Coords->GetPointer(0);
  for (int64_t p = 0; p < n; ++p)
  {
    const int64_t i = int64_t(ijk[3 * p]) - v.BoxMin[0], j = int64_t(ijk[3 * p + 1]) - v.BoxMin[1],
                  k = int64_t(ijk[3 * p + 2]) - v.BoxMin[2];
    if (i < 0 || i >= nx || j < 0 || j >= ny || k < 0 || k >= nz)
    {
      problem = "an active voxel lies outside the grid's index box";
      return false;
    }
    if (!active.insert((k * ny + j) * nx + i).second)
    {
      problem = "an active voxel is listed twice";
      return false;
    }
    double value = 0.0;
    if (nc == 1 || vectorMode == 1)
      value = v.Values->GetComponent(p, nc == 1 ? 0 : comp);
    else
    {
      for (int q = 0; q < nc; ++q)
        value += v.Values->GetComponent(p, q) * v.Values->GetComponent(p, q);
      value = std::sqrt(value);
    }
    bank.Xyz.push_back(UnitPosition(i, nx));
    bank.Xyz.push_back(UnitPosition(j, ny));
    bank.Xyz.push_back(UnitPosition(k, nz));
    bank.Values.push_back(value);
  }
  return true;
}

/// The occupancy of the macrocells (8 voxels a side, nv::macrocellLayout): those holding an active voxel, and the one
/// below along an axis where the voxel starts a cell.
std::vector<uint32_t> MacrocellOccupancy(const SparseVoxels& v)
{
  const int64_t boxDims[3] = { v.Dims[0], v.Dims[1], v.Dims[2] };
  const nv::MacrocellLayout cells = nv::macrocellLayout(boxDims);
  std::vector<uint32_t> occupancy(size_t((int64_t(cells.dims[0]) * cells.dims[1] * cells.dims[2] + 31) / 32), 0u);
  const int64_t n = v.Values->GetNumberOfTuples();
  const int* ijk = v.Coords->GetPointer(0);
  for (int64_t p = 0; p < n; ++p)
  {
    int first[3], last[3];
    for (int a = 0; a < 3; ++a)
    {
      const int64_t i = int64_t(ijk[3 * p + a]) - v.BoxMin[a];
      const int c = static_cast<int>(i / nv::kCellVoxels);
      first[a] = std::max(0, i % nv::kCellVoxels == 0 ? c - 1 : c);
      last[a] = std::min(cells.dims[a] - 1, c);
    }
    for (int z = first[2]; z <= last[2]; ++z)
      for (int y = first[1]; y <= last[1]; ++y)
        for (int x = first[0]; x <= last[0]; ++x)
        {
          const int64_t c = (int64_t(z) * cells.dims[1] + y) * cells.dims[0] + x;
          occupancy[size_t(c >> 5)] |= 1u << (c & 31);
        }
  }
  return occupancy;
}

/// Inactive voxels at the background value: distinct ones, drawn by rejection against the active set (bounded
/// attempts: a box that is nearly all active gives fewer); returns how many went to the bank.
int64_t BankBackgroundVoxels(
  const SparseVoxels& v, uint64_t seed, const std::unordered_set<int64_t>& active, SparseBank& bank)
{
  const int64_t nx = v.Dims[0], ny = v.Dims[1], nz = v.Dims[2];
  const int64_t total = nx * ny * nz;
  const int64_t n = v.Values->GetNumberOfTuples();
  const int64_t want = std::min<int64_t>(bank.Inactive, std::max<int64_t>(n, int64_t(1) << 18));
  std::unordered_set<int64_t> drawn;
  drawn.reserve(size_t(want));
  for (uint64_t attempt = 0; int64_t(drawn.size()) < want && attempt < uint64_t(want) * 8 + 1024; ++attempt)
  {
    const uint64_t h = nv::mix64(nv::mix64(seed ^ 0x5350415253ull) + attempt);
    const int64_t idx = static_cast<int64_t>((static_cast<unsigned __int128>(h) * uint64_t(total)) >> 64);
    if (active.count(idx) || !drawn.insert(idx).second)
      continue;
    const int64_t i = idx % nx, j = (idx / nx) % ny, k = idx / (nx * ny);
    bank.Xyz.push_back(UnitPosition(i, nx));
    bank.Xyz.push_back(UnitPosition(j, ny));
    bank.Xyz.push_back(UnitPosition(k, nz));
    bank.Values.push_back(v.Background);
  }
  return int64_t(drawn.size());
}

/// The bank's points where the error is measured (an even stride beyond SourceSamples::kMaxSourceSamples), in the
/// box's frame before its direction (the frame of the network's bounds).
std::shared_ptr<SourceSamples> SamplesOfBank(const SparseVoxels& v, const SparseBank& bank)
{
  auto samples = std::make_shared<SourceSamples>();
  const int64_t m = int64_t(bank.Values.size());
  const int64_t stride = std::max<int64_t>(1, (m + SourceSamples::kMaxSourceSamples - 1) / SourceSamples::kMaxSourceSamples);
  for (int64_t p = 0; p < m; p += stride)
  {
    for (int a = 0; a < 3; ++a)
    {
      const double len = (v.Dims[a] - 1) * v.Spacing[a];
      samples->Xyz.push_back(v.Origin[a] + (v.Dims[a] > 1 ? double(bank.Xyz[size_t(3 * p + a)]) * len : 0.0));
    }
    samples->Values.push_back(bank.Values[size_t(p)]);
  }
  samples->Total = m;
  samples->SourceBytes = int64_t(v.Values->GetNumberOfValues()) * std::max(1, v.Values->GetDataTypeSize());
  return samples;
}
} // namespace

bool MakeSparseBank(const SparseVoxels& v, int vectorMode, int component, uint64_t seed, SparseBank& bank,
  std::string& problem)
{
  std::unordered_set<int64_t> active;
  if (!BankActiveVoxels(v, vectorMode, component, bank, active, problem))
    return false;
  const int64_t n = v.Values->GetNumberOfTuples();
  bank.Active = n;
  bank.Inactive = int64_t(v.Dims[0]) * v.Dims[1] * v.Dims[2] - n;
  bank.Occupancy = MacrocellOccupancy(v);
  bank.Background = BankBackgroundVoxels(v, seed, active, bank);
  bank.Samples = SamplesOfBank(v, bank);
  return true;
}

} // namespace vtkNeuralCompressInternals
