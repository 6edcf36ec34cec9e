#include "vtkNeuralCompressInternals.h"

#include "Core/ResourceEstimate.h"

#include "vtkDataArray.h"
#include "vtkType.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace vtkNeuralCompressInternals
{
namespace
{

bool EngineType(int vtkType, nv::ScalarType& out)
{
  switch (vtkType)
  {
    case VTK_CHAR:
      out = std::numeric_limits<char>::is_signed ? nv::ScalarType::Int8 : nv::ScalarType::UInt8;
      return true;
    case VTK_SIGNED_CHAR:
      out = nv::ScalarType::Int8;
      return true;
    case VTK_UNSIGNED_CHAR:
      out = nv::ScalarType::UInt8;
      return true;
    case VTK_SHORT:
      out = nv::ScalarType::Int16;
      return true;
    case VTK_UNSIGNED_SHORT:
      out = nv::ScalarType::UInt16;
      return true;
    case VTK_INT:
      out = nv::ScalarType::Int32;
      return true;
    case VTK_UNSIGNED_INT:
      out = nv::ScalarType::UInt32;
      return true;
    case VTK_LONG:
      out = sizeof(long) == 8 ? nv::ScalarType::Int64 : nv::ScalarType::Int32;
      return true;
    case VTK_UNSIGNED_LONG:
      out = sizeof(unsigned long) == 8 ? nv::ScalarType::UInt64 : nv::ScalarType::UInt32;
      return true;
    case VTK_LONG_LONG:
      out = nv::ScalarType::Int64;
      return true;
    case VTK_UNSIGNED_LONG_LONG:
      out = nv::ScalarType::UInt64;
      return true;
    case VTK_ID_TYPE:
      out = sizeof(vtkIdType) == 8 ? nv::ScalarType::Int64 : nv::ScalarType::Int32;
      return true;
    case VTK_FLOAT:
      out = nv::ScalarType::Float32;
      return true;
    case VTK_DOUBLE:
      out = nv::ScalarType::Float64;
      return true;
    default:
      return false;
  }
}

} // namespace

OutputGeometry ComputeGeometry(const int ext[6], const double origin[3], const double spacing[3], bool cells,
  const int res[3], int finestResolution, int baseResolution)
{
  OutputGeometry g;
  g.OnSourceGrid = true;
  std::copy(ext, ext + 6, g.Extent);
  std::copy(origin, origin + 3, g.Origin);
  std::copy(spacing, spacing + 3, g.Spacing);
  for (int d = 0; d < 3; ++d)
  {
    const int points = std::max(ext[2 * d + 1] - ext[2 * d] + 1, 0);
    g.SourceDims[d] = cells ? std::max(points - 1, points > 0 ? 1 : 0) : points;
  }
  // The finest level as the filter trains it (vtkNeuralCompressStartJob: twice the largest dimension by default).
  const int64_t largest = std::max({ g.SourceDims[0], g.SourceDims[1], g.SourceDims[2] });
  const int64_t finest = finestResolution > 0 ? finestResolution
    : finestResolution == 0                   ? std::max<int64_t>(2 * largest, baseResolution)
                                              : int64_t(0);
  for (int d = 0; d < 3; ++d)
  {
    const int points = std::max(ext[2 * d + 1] - ext[2 * d] + 1, 0);
    int r = res[d] > 0 ? res[d] : g.SourceDims[d];
    const int64_t cap = std::max<int64_t>(finest * nv::kDecodeOversampling, g.SourceDims[d]);
    if (finest > 0 && r > cap)
    {
      r = static_cast<int>(std::min<int64_t>(cap, std::numeric_limits<int>::max()));
      g.CapSamples = static_cast<int>(std::min<int64_t>(finest, std::numeric_limits<int>::max()));
    }
    if (cells && points == 1)
    {
      r = 1; // a flat axis keeps its single layer of cells
    }
    g.DecodedDims[d] = r;
    if (r == g.SourceDims[d])
    {
      continue;
    }
    g.OnSourceGrid = false;
    const double b0 = origin[d] + ext[2 * d] * spacing[d];
    const double length = (points - 1) * spacing[d];
    g.Extent[2 * d] = 0;
    if (cells)
    {
      g.Extent[2 * d + 1] = r;
      g.Spacing[d] = length / r;
      g.Origin[d] = b0;
    }
    else
    {
      g.Extent[2 * d + 1] = r - 1;
      g.Spacing[d] = r > 1 ? length / (r - 1) : spacing[d];
      g.Origin[d] = r > 1 ? b0 : b0 + 0.5 * length;
    }
  }
  return g;
}

namespace
{
/// The first and last lattice index (Origin + index x Spacing, indices 0..last) of a resampled axis that a piece
/// owning [lo, hi] decodes: see PieceOfWholeGeometry.
void OutputLatticeRange(double lo, double hi, bool upperPiece, bool cells, double latticeOrigin, double latticeSpacing,
  int lastPoint, int& first, int& last)
{
  constexpr double slack = 1e-6; // in lattice steps: a sample on the boundary counts as on it
  const double shift = cells ? 0.5 : 0.0;  // cell centres
  const int lastSample = cells ? lastPoint - 1 : lastPoint;
  const double from = std::ceil((lo - latticeOrigin) / latticeSpacing - shift - slack);
  // The first sample at or beyond hi belongs to the upper neighbour.
  const double beyond = std::ceil((hi - latticeOrigin) / latticeSpacing - shift - slack);
  // An index in 0..lastSample (a non-finite position, which no valid image gives, counts as 0).
  auto clamped = [lastSample](double index) {
    return std::isfinite(index) ? static_cast<int>(std::min<double>(std::max(index, 0.0), lastSample)) : 0;
  };
  first = clamped(from);
  // Points: up to and including that neighbour's first sample (the shared layer); cells: its last own cell.
  last = std::max(first, clamped(upperPiece ? lastSample : cells ? beyond - 1.0 : beyond));
}
} // namespace

OutputGeometry PieceOfWholeGeometry(const OutputGeometry& whole, const int pieceExtent[6], const int owned[6],
  const int wholeExtent[6], const double origin[3], const double spacing[3], bool cells)
{
  const int sourceResolution[3] = { 0, 0, 0 };
  OutputGeometry g = ComputeGeometry(pieceExtent, origin, spacing, cells, sourceResolution);
  g.CapSamples = whole.CapSamples;
  for (int a = 0; a < 3; ++a)
  {
    if (whole.DecodedDims[a] == whole.SourceDims[a] || whole.DecodedDims[a] <= 1 || !(whole.Spacing[a] > 0.0))
      continue; // the source lattice (cropped by the filter), or a single layer every piece keeps
    const double lo = origin[a] + owned[2 * a] * spacing[a], hi = origin[a] + owned[2 * a + 1] * spacing[a];
    int first = 0, last = 0;
    OutputLatticeRange(std::min(lo, hi), std::max(lo, hi), owned[2 * a + 1] >= wholeExtent[2 * a + 1], cells,
      whole.Origin[a], whole.Spacing[a], whole.Extent[2 * a + 1], first, last);
    g.Extent[2 * a] = first;
    g.Extent[2 * a + 1] = cells ? last + 1 : last;
    g.Origin[a] = whole.Origin[a];
    g.Spacing[a] = whole.Spacing[a];
    g.DecodedDims[a] = last - first + 1;
    g.OnSourceGrid = false;
    g.WorldSamples = true;
  }
  return g;
}

bool MakeSourceField(vtkDataArray* array, int vectorMode, int component, const int64_t dims[3],
  SourceField& field, std::string& error)
{
  const int64_t n = dims[0] * dims[1] * dims[2];
  if (!array || array->GetNumberOfTuples() != n)
  {
    error = "the array has " + std::to_string(array ? array->GetNumberOfTuples() : 0) +
      " tuples, the grid needs " + std::to_string(n);
    return false;
  }
  const int nComp = array->GetNumberOfComponents();
  if (nComp < 1)
  {
    error = "the array has no components";
    return false;
  }
  field.View.dims[0] = dims[0];
  field.View.dims[1] = dims[1];
  field.View.dims[2] = dims[2];

  nv::ScalarType nativeType;
  const bool known = EngineType(array->GetDataType(), nativeType);
  const int64_t elementBytes = std::max(1, array->GetDataTypeSize());
  field.RawBytes = n * elementBytes;

  if (nComp == 1 && known && array->HasStandardMemoryLayout())
  {
    // In place: no copy.
    field.View.data = array->GetVoidPointer(0);
    field.View.type = nativeType;
    field.Description = "";
    return true;
  }

  if (nComp > 1 && vectorMode == 1 && component >= nComp)
  {
    error = "VectorComponent " + std::to_string(component) + " is out of range: the array has " +
      std::to_string(nComp) + " components";
    return false;
  }

  // A float copy (magnitude or one component); keeps NaN/Inf so they are counted as invalid.
  field.Storage.resize(static_cast<size_t>(n) * sizeof(float));
  float* dst = reinterpret_cast<float*>(field.Storage.data());
  if (nComp == 1 || vectorMode == 1)
  {
    const int c = nComp == 1 ? 0 : component;
    for (int64_t i = 0; i < n; ++i)
    {
      dst[i] = static_cast<float>(array->GetComponent(i, c));
    }
    field.Description =
      nComp == 1 ? "" : "component " + std::to_string(c) + " of " + std::to_string(nComp);
  }
  else
  {
    for (int64_t i = 0; i < n; ++i)
    {
      double s = 0.0;
      for (int c = 0; c < nComp; ++c)
      {
        const double v = array->GetComponent(i, c);
        s += v * v;
      }
      dst[i] = static_cast<float>(std::sqrt(s));
    }
    field.Description = "magnitude of " + std::to_string(nComp) + " components";
    field.RawBytes = n * std::max<int64_t>(elementBytes, sizeof(float));
  }
  field.View.data = dst;
  field.View.type = nv::ScalarType::Float32;
  return true;
}

} // namespace vtkNeuralCompressInternals
