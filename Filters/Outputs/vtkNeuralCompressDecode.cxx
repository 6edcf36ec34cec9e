#include "vtkNeuralCompressDecode.h"

#include "vtkNeuralCompress.h"
#include "vtkNeuralOutOfCoreInput.h"

#include "Core/Macrocells.h"
#include "Core/ResourceEstimate.h"
#include "Core/ValueRange.h"

#include "vtkBitArray.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkType.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace vtkNeuralCompressInternals
{
namespace
{
/// A grid is decoded by slabs of rows (decodeGrid, parallel over rows) when it has at least this many rows per chunk;
/// a grid of a few very long rows (e.g. 2^31 x 1 x 1) is decoded as points, parallel over points.
constexpr int64_t kMinRowsPerChunk = 64;

/// The coordinate decodeGrid gives sample i of n (0.5 for a single sample).
float GridCoordinate(int64_t i, int64_t n)
{
  return n <= 1 ? 0.5f : static_cast<float>(static_cast<double>(i) / static_cast<double>(n - 1));
}

/// Polls the control between chunks and reports the fraction done (every 1%).
class ChunkTicker
{
public:
  ChunkTicker(const DecodeControl& control, int64_t total)
    : Control(control)
    , Total(std::max<int64_t>(total, 1))
  {
  }
  void Done(int64_t samples)
  {
    if (this->Control.Abort && this->Control.Abort())
      throw DecodeAborted();
    if (this->Control.Progress)
    {
      const double f = static_cast<double>(samples) / static_cast<double>(this->Total);
      if (f - this->Last >= 0.01 || samples >= this->Total)
      {
        this->Control.Progress(std::min(f, 1.0));
        this->Last = f;
      }
    }
  }

private:
  const DecodeControl& Control;
  int64_t Total;
  double Last = 0.0;
};

/// Decoded values (source units) at `count` points (xyz in [0,1]^3, interleaved), in chunks written to out.
template <typename T>
void DecodePointsChunk(nv::NetworkSession& session, const float* xyz, int64_t count, const nv::ValueRange& range, T* out,
  std::vector<float>& normalised)
{
  normalised.resize(static_cast<size_t>(count));
  session.inferPoints(xyz, count, normalised.data(), nv::Memory::Host);
  for (int64_t i = 0; i < count; ++i)
    out[i] = nv::storedValue<T>(range.denormalize(static_cast<double>(normalised[static_cast<size_t>(i)])));
}

/// Decoded values (source units) of the output samples, in float or double, in chunks of about kDecodeChunk.
template <typename T>
void DecodeValues(nv::NetworkSession& session, const FieldInfo& f, T* out, const DecodeControl& control)
{
  const OutputGeometry& g = f.Geometry;
  const int64_t n[3] = { g.DecodedDims[0], g.DecodedDims[1], g.DecodedDims[2] };
  const int64_t count = n[0] * n[1] * n[2];
  ChunkTicker ticker(control, count);
  const nv::SourceInfo& src = session.model().source;
  const nv::ValueRange range(src.valueMin, src.valueMax); // also wider than the largest double (ValueRange.h)
  const bool onGrid = (!f.Cells || g.OnSourceGrid) && !g.WorldSamples;
  const int64_t slice = n[0] * n[1];
  const int64_t slabs = std::max<int64_t>(1, kDecodeChunk / slice);
  if (onGrid && ((slice <= kDecodeChunk && slabs * n[1] >= kMinRowsPerChunk) || count <= kDecodeChunk))
  {
    // Slabs of z slices: decodeGrid is parallel over their rows. A slice of more than kDecodeChunk samples is decoded
    // as points below instead, so that no chunk between two polls is larger than that.
    for (int64_t z0 = 0; z0 < n[2]; z0 += slabs)
    {
      const int64_t z1 = std::min(n[2], z0 + slabs);
      nv::decodeGridValues(session, n[0], n[1], n[2], z0, z1, out + z0 * slice);
      ticker.Done(z1 * slice);
    }
    return;
  }
  // As points, kDecodeChunk at a time: grid coordinates (decodeGrid's convention), or the world positions of the
  // samples (the cell centres of a resampled cell output, a piece's part of the whole lattice) in the source's
  // normalised coordinates.
  std::vector<float> xyz, normalised;
  // The error-bounded mode's corrections on the source's own grid (decodeGridValues applies them above).
  const std::shared_ptr<const nv::ErrorCorrections> corrections =
    onGrid && n[0] == src.dims[0] && n[1] == src.dims[1] && n[2] == src.dims[2] ? session.errorCorrections() : nullptr;
  for (int64_t i0 = 0; i0 < count; i0 += kDecodeChunk)
  {
    const int64_t m = std::min(kDecodeChunk, count - i0);
    xyz.resize(static_cast<size_t>(3 * m));
    for (int64_t k = 0; k < m; ++k)
    {
      const int64_t i = i0 + k;
      const int64_t ijk[3] = { i % n[0], (i / n[0]) % n[1], i / slice };
      for (int d = 0; d < 3; ++d)
      {
        float u = GridCoordinate(ijk[d], n[d]);
        if (!onGrid)
        {
          // World samples: points, or cell centres (the extent's first index: a piece's part of the whole lattice).
          const double index = static_cast<double>(g.Extent[2 * d] + ijk[d]) + (f.Cells ? 0.5 : 0.0);
          const double world = g.Origin[d] + index * g.Spacing[d];
          const double extent = src.bounds[2 * d + 1] - src.bounds[2 * d];
          const double v = extent > 0 ? (world - src.bounds[2 * d]) / extent : 0.5;
          u = static_cast<float>(std::min(1.0, std::max(0.0, v)));
        }
        xyz[static_cast<size_t>(3 * k + d)] = u;
      }
    }
    DecodePointsChunk(session, xyz.data(), m, range, out + i0, normalised);
    if (corrections)
      nv::applyCorrections(*corrections, i0, m, out + i0);
    ticker.Done(i0 + m);
  }
}

/// Round and clamp into an integer (or keep a float) array of the input's type.
template <typename In, typename Out>
void StoreAs(const In* in, int64_t n, Out* out)
{
  if (std::numeric_limits<Out>::is_integer)
  {
    // The limits as doubles: 2^63 and 2^64 are one past the largest 64-bit values, so compare before converting.
    const double lo = static_cast<double>(std::numeric_limits<Out>::lowest());
    const double hi = static_cast<double>(std::numeric_limits<Out>::max());
    for (int64_t i = 0; i < n; ++i)
    {
      const double v = std::isfinite(static_cast<double>(in[i])) ? std::nearbyint(static_cast<double>(in[i])) : 0.0;
      out[i] = v >= hi ? std::numeric_limits<Out>::max()
        : v <= lo      ? std::numeric_limits<Out>::lowest()
                       : static_cast<Out>(v);
    }
  }
  else
  {
    for (int64_t i = 0; i < n; ++i)
    {
      out[i] = static_cast<Out>(in[i]);
    }
  }
}

/// A bit array (vtkTemplateMacro has no VTK_BIT case): 1 where the decoded value is at least 0.5, else 0 (NaN too).
void StoreAsBits(vtkDataArray* decoded, int64_t n, vtkBitArray* out)
{
  auto* d = vtkDoubleArray::SafeDownCast(decoded);
  auto* f = vtkFloatArray::SafeDownCast(decoded);
  for (int64_t i = 0; i < n; ++i)
  {
    const double v = d ? d->GetValue(i) : static_cast<double>(f->GetValue(i));
    out->SetValue(i, v >= 0.5 ? 1 : 0);
  }
}

/// NaN at the decoded points whose nearest source sample is outside the domain of a resampled input.
void MaskOutside(const FieldInfo& f, vtkDataArray* array)
{
  const OutputGeometry& g = f.Geometry;
  const std::vector<uint8_t>& outside = *f.Outside;
  if (int64_t(outside.size()) != int64_t(g.SourceDims[0]) * g.SourceDims[1] * g.SourceDims[2])
  {
    return;
  }
  std::vector<int64_t> map[3];
  for (int a = 0; a < 3; ++a)
  {
    const int nd = g.DecodedDims[a], ns = g.SourceDims[a];
    map[a].resize(size_t(nd));
    for (int i = 0; i < nd; ++i)
    {
      if (g.WorldSamples)
      {
        // The source sample nearest to the decoded one's world position (a piece's part of the whole lattice).
        const double index = static_cast<double>(g.Extent[2 * a] + i) + (f.Cells ? 0.5 : 0.0);
        const double world = g.Origin[a] + index * g.Spacing[a];
        const double source = f.InputSpacing[a] != 0.0
          ? (world - f.InputOrigin[a]) / f.InputSpacing[a] - f.InputExtent[2 * a] - (f.Cells ? 0.5 : 0.0)
          : 0.0;
        map[a][size_t(i)] = std::min<int64_t>(std::max<int64_t>(std::llround(source), 0), std::max(ns - 1, 0));
      }
      else
        map[a][size_t(i)] = nd > 1 && ns > 1 ? std::llround(double(i) * (ns - 1) / (nd - 1)) : 0;
    }
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  vtkIdType k = 0;
  for (int z = 0; z < g.DecodedDims[2]; ++z)
    for (int y = 0; y < g.DecodedDims[1]; ++y)
      for (int x = 0; x < g.DecodedDims[0]; ++x, ++k)
      {
        const int64_t s = (map[2][size_t(z)] * g.SourceDims[1] + map[1][size_t(y)]) * g.SourceDims[0] + map[0][size_t(x)];
        if (outside[size_t(s)])
          array->SetComponent(k, 0, nan);
      }
}

/// A sparse input: the decoded samples in its empty macrocells are its background exactly (as the renderers draw
/// them; nv::SourceInfo::occupancy).
void SetEmptyCells(const FieldInfo& f, vtkDataArray* array)
{
  const OutputGeometry& g = f.Geometry;
  const int64_t sdims[3] = { g.SourceDims[0], g.SourceDims[1], g.SourceDims[2] };
  if (int64_t(f.Occupancy->size()) != nv::occupancyWords(sdims))
    return;
  const nv::MacrocellLayout cells = nv::macrocellLayout(sdims);
  vtkIdType k = 0;
  for (int z = 0; z < g.DecodedDims[2]; ++z)
    for (int y = 0; y < g.DecodedDims[1]; ++y)
      for (int x = 0; x < g.DecodedDims[0]; ++x, ++k)
      {
        // The network coordinate of the decoded sample (decodeGrid's convention).
        if (!nv::cellOccupied(f.Occupancy->data(), cells, GridCoordinate(x, g.DecodedDims[0]),
              GridCoordinate(y, g.DecodedDims[1]), GridCoordinate(z, g.DecodedDims[2])))
          array->SetComponent(k, 0, f.Background);
      }
}

/// Decoded in double precision for float64 and 32/64-bit integer inputs, and for a float32 output that float32
/// cannot hold (it is then float64; the filter warns).
bool DecodeInDouble(const FieldInfo& f, int outputMode)
{
  const bool wideInput = f.VtkType == VTK_DOUBLE || f.VtkType == VTK_LONG_LONG ||
    f.VtkType == VTK_UNSIGNED_LONG_LONG || f.VtkType == VTK_LONG || f.VtkType == VTK_UNSIGNED_LONG ||
    f.VtkType == VTK_ID_TYPE || f.VtkType == VTK_INT || f.VtkType == VTK_UNSIGNED_INT;
  return (outputMode == vtkNeuralCompress::OUTPUT_INPUT_TYPE && wideInput) ||
    (outputMode == vtkNeuralCompress::OUTPUT_FLOAT32 && !Float32Holds(f.Stats.min, f.Stats.max));
}

/// The decoded array in the input's type (OUTPUT_INPUT_TYPE and another type than `decoded`'s), else null.
vtkSmartPointer<vtkDataArray> Typed(const FieldInfo& f, int outputMode, vtkDataArray* decoded, int64_t count)
{
  if (outputMode != vtkNeuralCompress::OUTPUT_INPUT_TYPE || f.VtkType == decoded->GetDataType())
    return nullptr;
  vtkSmartPointer<vtkDataArray> typed = vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(f.VtkType));
  if (!typed)
    return nullptr;
  typed->SetNumberOfTuples(count);
  if (auto* bits = vtkBitArray::SafeDownCast(typed))
  {
    StoreAsBits(decoded, count, bits);
    return typed;
  }
  void* out = typed->GetVoidPointer(0);
  if (auto* d = vtkDoubleArray::SafeDownCast(decoded))
  {
    const double* in = d->GetPointer(0);
    switch (f.VtkType)
    {
      vtkTemplateMacro(StoreAs(in, count, static_cast<VTK_TT*>(out)));
      default:
        break;
    }
  }
  else
  {
    const float* in = vtkFloatArray::SafeDownCast(decoded)->GetPointer(0);
    switch (f.VtkType)
    {
      vtkTemplateMacro(StoreAs(in, count, static_cast<VTK_TT*>(out)));
      default:
        break;
    }
  }
  return typed;
}
} // namespace

int64_t DecodedOutputBytes(const FieldInfo& f, int outputMode)
{
  if (outputMode == vtkNeuralCompress::OUTPUT_NETWORK_ONLY)
    return 0;
  const OutputGeometry& g = f.Geometry;
  const int64_t count =
    nv::saturatingMul(nv::saturatingMul(std::max(g.DecodedDims[0], 0), std::max(g.DecodedDims[1], 0)),
      std::max(g.DecodedDims[2], 0));
  const bool wide = DecodeInDouble(f, outputMode);
  int64_t perSample = wide ? 8 : 4;
  const int decodedType = wide ? VTK_DOUBLE : VTK_FLOAT;
  if (outputMode == vtkNeuralCompress::OUTPUT_INPUT_TYPE && f.VtkType != decodedType)
    perSample += std::max(vtkAbstractArray::GetDataTypeSize(f.VtkType), 1); // the copy in the input's type
  int64_t bytes = nv::saturatingMul(count, perSample);
  // The measurement at the phase's end decodes the source grid in double precision unless the output is it in float.
  if (wide || !g.OnSourceGrid)
  {
    const int64_t source = nv::saturatingMul(
      nv::saturatingMul(std::max(g.SourceDims[0], 0), std::max(g.SourceDims[1], 0)), std::max(g.SourceDims[2], 0));
    bytes = nv::saturatingAdd(bytes, nv::saturatingMul(source, 8));
  }
  return bytes;
}

void CheckDecodedOutputMemory(const FieldInfo& f, int outputMode)
{
  nv::MemoryEstimate e;
  e.hostBytes = DecodedOutputBytes(f, outputMode);
  std::ostringstream d;
  d << f.Geometry.DecodedDims[0] << " x " << f.Geometry.DecodedDims[1] << " x " << f.Geometry.DecodedDims[2]
    << " samples in " << (DecodeInDouble(f, outputMode) ? "float64" : "float32");
  e.detail = d.str();
  nv::checkMemory(e, "the decoded output", "Lower OutputResolution, or choose OutputMode 'Network only' (the Neural "
                                           "Volume representation renders the network without a decoded field)");
}

vtkSmartPointer<vtkDataArray> DecodeOutput(
  nv::NetworkSession& session, const FieldInfo& f, int outputMode, const DecodeControl& control)
{
  if (outputMode == vtkNeuralCompress::OUTPUT_NETWORK_ONLY)
  {
    return nullptr;
  }
  CheckDecodedOutputMemory(f, outputMode);
  CheckOutOfCoreDecode(f, outputMode);
  const OutputGeometry& g = f.Geometry;
  const int64_t count = int64_t(g.DecodedDims[0]) * g.DecodedDims[1] * g.DecodedDims[2];
  vtkSmartPointer<vtkDataArray> array;
  if (DecodeInDouble(f, outputMode))
  {
    auto d = vtkSmartPointer<vtkDoubleArray>::New();
    if (!d->Allocate(count) || (d->SetNumberOfTuples(count), d->GetNumberOfTuples() != count))
      throw nv::Error("out of memory for the decoded output (" + nv::formatBytes(count * 8) + ")");
    DecodeValues(session, f, d->GetPointer(0), control);
    array = d;
  }
  else
  {
    auto values = vtkSmartPointer<vtkFloatArray>::New();
    if (!values->Allocate(count) || (values->SetNumberOfTuples(count), values->GetNumberOfTuples() != count))
      throw nv::Error("out of memory for the decoded output (" + nv::formatBytes(count * 4) + ")");
    DecodeValues(session, f, values->GetPointer(0), control);
    array = values;
  }
  if (vtkSmartPointer<vtkDataArray> typed = Typed(f, outputMode, array, count))
  {
    array = typed;
  }
  if (f.Outside && (array->GetDataType() == VTK_FLOAT || array->GetDataType() == VTK_DOUBLE))
  {
    MaskOutside(f, array);
  }
  if (f.Occupancy)
  {
    SetEmptyCells(f, array);
  }
  array->SetName(f.Name.c_str());
  return array;
}

nv::ErrorStats CompareDecodedOutput(
  vtkDataArray* decoded, const nv::VolumeView& source, double valueMin, double valueMax, int threads)
{
  if (auto* f = vtkFloatArray::SafeDownCast(decoded))
    return nv::compareDecoded(f->GetPointer(0), source, valueMin, valueMax, threads);
  if (auto* d = vtkDoubleArray::SafeDownCast(decoded))
    return nv::compareDecoded(d->GetPointer(0), source, valueMin, valueMax, threads);
  // Integers and bits: their values as doubles (a 64-bit integer rounds by at most 2^-53 of itself).
  std::vector<double> values(static_cast<size_t>(decoded->GetNumberOfTuples()));
  for (vtkIdType i = 0; i < decoded->GetNumberOfTuples(); ++i)
    values[static_cast<size_t>(i)] = decoded->GetComponent(i, 0);
  return nv::compareDecoded(values.data(), source, valueMin, valueMax, threads);
}

} // namespace vtkNeuralCompressInternals
