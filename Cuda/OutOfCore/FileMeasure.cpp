// NeuralVolume engine, out-of-core training: streamed figures over a volume file (FileMeasure.h).
#include "FileMeasure.h"

#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "Core/ValueRange.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <mutex>
#include <thread>
#include <vector>

namespace nv
{
namespace
{
/// Slices per slab so that `doubles` slabs of doubles and one of floats stay within slabBytes.
int64_t slicesPerSlab(const VolumeFileLayout& layout, int64_t slabBytes, int64_t doubles)
{
  const int64_t sliceBytes =
    layout.dims[0] * layout.dims[1] * static_cast<int64_t>(doubles * sizeof(double) + sizeof(float));
  return std::max<int64_t>(1, std::min(layout.dims[2], slabBytes / std::max<int64_t>(1, sliceBytes)));
}

void report(const FileProgress& progress, double fraction)
{
  if (progress && !progress(fraction))
    NV_THROW("stopped");
}

/// Threads of a streamed pass: reading (pread, the conversion) and the per-sample work run on every core (at most 16);
/// a box source (chunked HDF5: one lock, a decoded chunk held per call) is read by one.
int passThreads(const VolumeFileReader& reader)
{
  if (reader.layout().boxSource)
    return 1;
  return static_cast<int>(std::min(16u, std::max(1u, std::thread::hardware_concurrency())));
}

/// work(z0, z1, thread) over the slices [0, slices) of a slab, split among the threads; the first error is rethrown.
void forSliceRanges(int64_t slices, int threads, const std::function<void(int64_t, int64_t, int)>& work)
{
  const int count = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(threads, slices)));
  std::exception_ptr failure;
  std::mutex failureMutex;
  auto run = [&](int t) {
    try
    {
      work(slices * t / count, slices * (t + 1) / count, t);
    }
    catch (...)
    {
      std::lock_guard<std::mutex> lock(failureMutex);
      if (!failure)
        failure = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < count; ++t)
    pool.emplace_back(run, t);
  run(0);
  for (std::thread& thread : pool)
    thread.join();
  if (failure)
    std::rethrow_exception(failure);
}

/// One thread's error sums over the exact pass (compareDecoded's, CpuCompareDecoded.cpp).
struct SlabSums
{
  double squared = 0.0, maxAbs = 0.0, maxOfRange = 0.0;
  int64_t count = 0, bad = 0;
};

/// Samples [b, e) of a slab against the network's normalised values, de-normalised as a decoded double output is
/// (range.denormalize), added to `sums` (in locals while the loop runs: the threads' entries share cache lines).
void compareSlab(const float* normalised, const double* samples, int64_t b, int64_t e, const ValueRange& range,
  SlabSums& sums)
{
  SlabSums local = sums;
  const bool spans = range.spans();
  for (int64_t i = b; i < e; ++i)
  {
    const double x = samples[i];
    if (!std::isfinite(x))
      continue;
    const double d = range.denormalize(static_cast<double>(normalised[i]));
    if (!std::isfinite(d))
    {
      ++local.bad;
      ++local.count;
      continue;
    }
    const double dn = spans ? range.normalize(d) - range.normalize(x) : d - x;
    local.squared += dn * dn;
    local.maxAbs = std::max(local.maxAbs, std::fabs(spans ? range.span(dn) : dn));
    local.maxOfRange = std::max(local.maxOfRange, std::fabs(dn));
    ++local.count;
  }
  sums = local;
}

/// The threads' sums as compareDecoded's figures.
ErrorStats mergeSums(const std::vector<SlabSums>& parts)
{
  ErrorStats total;
  double squaredSum = 0.0;
  for (const SlabSums& part : parts)
  {
    squaredSum += part.squared;
    total.count += part.count;
    total.nonFinite += part.bad;
    total.maxAbsError = std::max(total.maxAbsError, part.maxAbs);
    total.maxErrorOfRange = std::max(total.maxErrorOfRange, part.maxOfRange);
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
} // namespace

FileValueRange scanValueRange(const VolumeFileReader& reader, int64_t slabBytes, const FileProgress& progress)
{
  const VolumeFileLayout& layout = reader.layout();
  const int64_t slices = slicesPerSlab(layout, slabBytes, 1);
  const int64_t plane = layout.dims[0] * layout.dims[1];
  const int threads = passThreads(reader);
  std::vector<double> slab(static_cast<size_t>(plane * slices));
  std::vector<FileValueRange> parts(static_cast<size_t>(threads));
  for (FileValueRange& part : parts)
  {
    part.min = std::numeric_limits<double>::infinity();
    part.max = -std::numeric_limits<double>::infinity();
  }
  for (int64_t z0 = 0; z0 < layout.dims[2]; z0 += slices)
  {
    const int64_t nz = std::min(slices, layout.dims[2] - z0);
    forSliceRanges(nz, threads, [&](int64_t k0, int64_t k1, int t) {
      if (k0 == k1)
        return;
      double* part = slab.data() + k0 * plane;
      reader.readBox({ 0, 0, z0 + k0 }, { layout.dims[0], layout.dims[1], k1 - k0 }, part);
      // In locals, merged once: the threads' neighbouring entries of `parts` share cache lines.
      FileValueRange r = parts[static_cast<size_t>(t)];
      for (int64_t i = 0; i < plane * (k1 - k0); ++i)
      {
        const double v = part[i];
        if (!std::isfinite(v))
        {
          ++r.nonFinite;
          continue;
        }
        r.min = std::min(r.min, v);
        r.max = std::max(r.max, v);
        ++r.finite;
      }
      parts[static_cast<size_t>(t)] = r;
    });
    report(progress, double(z0 + nz) / double(layout.dims[2]));
  }
  FileValueRange r = parts[0];
  for (size_t t = 1; t < parts.size(); ++t)
  {
    r.min = std::min(r.min, parts[t].min);
    r.max = std::max(r.max, parts[t].max);
    r.finite += parts[t].finite;
    r.nonFinite += parts[t].nonFinite;
  }
  if (r.finite == 0)
    r.min = r.max = 0.0;
  return r;
}

ErrorStats measureOnFile(NetworkSession& session, const VolumeFileReader& reader, double valueMin, double valueMax,
  int64_t slabBytes, const FileProgress& progress)
{
  const int64_t* dims = reader.layout().dims;
  const int64_t lo[3] = { 0, 0, 0 }, hi[3] = { dims[0] - 1, dims[1] - 1, dims[2] - 1 };
  return measureBoxOnFile(session, reader, lo, hi, valueMin, valueMax, slabBytes, progress);
}

ErrorStats measureBoxOnFile(NetworkSession& session, const VolumeFileReader& reader, const int64_t lo[3],
  const int64_t hi[3], double valueMin, double valueMax, int64_t slabBytes, const FileProgress& progress)
{
  const VolumeFileLayout& layout = reader.layout();
  for (int axis = 0; axis < 3; ++axis)
    NV_CHECK(lo[axis] >= 0 && lo[axis] <= hi[axis] && hi[axis] < layout.dims[axis],
      "the box measured must lie inside the volume");
  // Two slabs of samples: the next one is read while this one is decoded and compared.
  const int64_t slices = slicesPerSlab(layout, slabBytes, 2);
  const int64_t bx = hi[0] - lo[0] + 1, by = hi[1] - lo[1] + 1, depth = hi[2] - lo[2] + 1;
  const int64_t plane = bx * by, gridPlane = layout.dims[0] * layout.dims[1];
  const bool wholePlanes = plane == gridPlane;
  std::vector<double> samples[2];
  for (std::vector<double>& slab : samples)
    slab.resize(static_cast<size_t>(plane * slices));
  std::vector<float> decoded(static_cast<size_t>(gridPlane * slices));
  std::vector<float> boxed(wholePlanes ? 0 : static_cast<size_t>(plane * slices));
  const ValueRange range(valueMin, valueMax);
  const int threads = passThreads(reader);
  std::vector<SlabSums> parts(static_cast<size_t>(threads));
  auto readSlab = [&](int64_t z0, std::vector<double>& into) {
    const int64_t nz = std::min(slices, depth - z0);
    forSliceRanges(nz, threads, [&](int64_t k0, int64_t k1, int) {
      if (k0 < k1)
        reader.readBox({ lo[0], lo[1], lo[2] + z0 + k0 }, { bx, by, k1 - k0 }, into.data() + k0 * plane);
    });
  };
  readSlab(0, samples[0]);
  for (int64_t z0 = 0, current = 0; z0 < depth; z0 += slices, current ^= 1)
  {
    const int64_t nz = std::min(slices, depth - z0);
    std::exception_ptr readFailure;
    std::thread next; // the next slab's reads, beside this one's decoding and comparison
    if (z0 + slices < depth)
      next = std::thread([&]() {
        try
        {
          readSlab(z0 + slices, samples[current ^ 1]);
        }
        catch (...)
        {
          readFailure = std::current_exception();
        }
      });
    try
    {
      session.decodeGrid(layout.dims[0], layout.dims[1], layout.dims[2], lo[2] + z0, lo[2] + z0 + nz, decoded.data());
      for (int64_t row = 0; !wholePlanes && row < nz * by; ++row) // the box's rows of the decoded planes
        std::copy_n(decoded.data() + (row / by) * gridPlane + (lo[1] + row % by) * layout.dims[0] + lo[0], bx,
          boxed.data() + row * bx);
      const float* normalised = wholePlanes ? decoded.data() : boxed.data();
      const double* source = samples[current].data();
      forSliceRanges(nz, threads, [&](int64_t k0, int64_t k1, int t) {
        compareSlab(normalised, source, k0 * plane, k1 * plane, range, parts[static_cast<size_t>(t)]);
      });
      report(progress, double(z0 + nz) / double(depth));
    }
    catch (...)
    {
      if (next.joinable())
        next.join();
      throw;
    }
    if (next.joinable())
      next.join();
    if (readFailure)
      std::rethrow_exception(readFailure);
  }
  return mergeSums(parts);
}

} // namespace nv
