// NeuralVolume engine, out-of-core training: streamed figures over a volume file (FileMeasure.h).
#include "FileMeasure.h"

#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "Core/ValueRange.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace nv
{
namespace
{
/// Slices per slab so that a slab of doubles (and its decoded floats) stays within slabBytes.
int64_t slicesPerSlab(const VolumeFileLayout& layout, int64_t slabBytes)
{
  const int64_t sliceBytes = layout.dims[0] * layout.dims[1] * static_cast<int64_t>(sizeof(double) + sizeof(float));
  return std::max<int64_t>(1, std::min(layout.dims[2], slabBytes / std::max<int64_t>(1, sliceBytes)));
}

void report(const FileProgress& progress, double fraction)
{
  if (progress && !progress(fraction))
    NV_THROW("stopped");
}
} // namespace

FileValueRange scanValueRange(const VolumeFileReader& reader, int64_t slabBytes, const FileProgress& progress)
{
  const VolumeFileLayout& layout = reader.layout();
  const int64_t slices = slicesPerSlab(layout, slabBytes);
  std::vector<double> slab(static_cast<size_t>(layout.dims[0] * layout.dims[1] * slices));
  FileValueRange r;
  r.min = std::numeric_limits<double>::infinity();
  r.max = -std::numeric_limits<double>::infinity();
  for (int64_t z0 = 0; z0 < layout.dims[2]; z0 += slices)
  {
    const int64_t nz = std::min(slices, layout.dims[2] - z0);
    reader.readBox({ 0, 0, z0 }, { layout.dims[0], layout.dims[1], nz }, slab.data());
    for (int64_t i = 0; i < layout.dims[0] * layout.dims[1] * nz; ++i)
    {
      const double v = slab[static_cast<size_t>(i)];
      if (!std::isfinite(v))
      {
        ++r.nonFinite;
        continue;
      }
      r.min = std::min(r.min, v);
      r.max = std::max(r.max, v);
      ++r.finite;
    }
    report(progress, double(z0 + nz) / double(layout.dims[2]));
  }
  if (r.finite == 0)
    r.min = r.max = 0.0;
  return r;
}

ErrorStats measureOnFile(NetworkSession& session, const VolumeFileReader& reader, double valueMin, double valueMax,
  int64_t slabBytes, const FileProgress& progress)
{
  const VolumeFileLayout& layout = reader.layout();
  const int64_t slices = slicesPerSlab(layout, slabBytes);
  const int64_t plane = layout.dims[0] * layout.dims[1];
  std::vector<double> samples(static_cast<size_t>(plane * slices)), decoded(static_cast<size_t>(plane * slices));
  std::vector<float> normalised(static_cast<size_t>(plane * slices));
  const ValueRange range(valueMin, valueMax);
  ErrorStats total;
  double squaredSum = 0.0;
  for (int64_t z0 = 0; z0 < layout.dims[2]; z0 += slices)
  {
    const int64_t nz = std::min(slices, layout.dims[2] - z0);
    reader.readBox({ 0, 0, z0 }, { layout.dims[0], layout.dims[1], nz }, samples.data());
    session.decodeGrid(layout.dims[0], layout.dims[1], layout.dims[2], z0, z0 + nz, normalised.data());
    for (int64_t i = 0; i < plane * nz; ++i)
      decoded[static_cast<size_t>(i)] = range.denormalize(normalised[static_cast<size_t>(i)]);
    VolumeView slab;
    slab.data = samples.data();
    slab.type = ScalarType::Float64;
    slab.dims[0] = layout.dims[0];
    slab.dims[1] = layout.dims[1];
    slab.dims[2] = nz;
    const ErrorStats part = compareDecoded(decoded.data(), slab, valueMin, valueMax, 1);
    squaredSum += std::isfinite(part.mse) ? part.mse * double(part.count) : 0.0;
    total.count += part.count;
    total.nonFinite += part.nonFinite;
    total.maxAbsError = std::max(total.maxAbsError, part.maxAbsError);
    total.maxErrorOfRange = std::max(total.maxErrorOfRange, part.maxErrorOfRange);
    report(progress, double(z0 + nz) / double(layout.dims[2]));
  }
  if (total.nonFinite > 0)
  {
    total.mse = total.psnr = std::numeric_limits<double>::quiet_NaN();
    total.maxAbsError = total.maxErrorOfRange = std::numeric_limits<double>::infinity();
    return total;
  }
  total.mse = total.count > 0 ? squaredSum / double(total.count) : 0.0;
  total.psnr = total.mse > 0.0 ? 10.0 * std::log10(1.0 / total.mse) : std::numeric_limits<double>::infinity();
  return total;
}

} // namespace nv
