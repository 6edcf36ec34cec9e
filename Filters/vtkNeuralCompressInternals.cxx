#include "vtkNeuralCompressInternals.h"

#include "vtkDataArray.h"
#include "vtkType.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

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

double Seconds(std::chrono::steady_clock::time_point since)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

} // namespace

OutputGeometry ComputeGeometry(
  const int ext[6], const double origin[3], const double spacing[3], bool cells, const int res[3])
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
    int r = res[d] > 0 ? res[d] : g.SourceDims[d];
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

double PsnrFromMse(double mse)
{
  return mse > 0.0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
}

PsnrProbe::PsnrProbe(const nv::VolumeView& view, uint64_t seed, int64_t maxSamples)
{
  const int64_t n = view.count();
  const double range = view.valueMax - view.valueMin;
  const double inv = range > 0.0 ? 1.0 / range : 0.0;
  std::mt19937_64 rng(seed ^ 0x5EED5EEDull);
  std::uniform_int_distribution<int64_t> pick(0, std::max<int64_t>(n - 1, 0));
  const int64_t want = std::min(n, maxSamples);
  const int64_t maxTries = want * 4 + 16;
  Coords.reserve(static_cast<size_t>(want) * 3);
  Expected.reserve(static_cast<size_t>(want));
  for (int64_t t = 0; t < maxTries && static_cast<int64_t>(Expected.size()) < want; ++t)
  {
    // Every voxel when the volume is small, else a random subset.
    const int64_t i = n <= maxSamples ? t : pick(rng);
    if (i >= n)
    {
      break;
    }
    const double v = view.at(i);
    if (!std::isfinite(v))
    {
      continue;
    }
    const int64_t x = i % view.dims[0];
    const int64_t y = (i / view.dims[0]) % view.dims[1];
    const int64_t z = i / (view.dims[0] * view.dims[1]);
    const int64_t idx[3] = { x, y, z };
    for (int d = 0; d < 3; ++d)
    {
      const int64_t m = view.dims[d];
      Coords.push_back(m > 1 ? static_cast<float>(static_cast<double>(idx[d]) / (m - 1)) : 0.5f);
    }
    Expected.push_back(static_cast<float>((v - view.valueMin) * inv));
  }
}

double PsnrProbe::Estimate(const nv::Model& model, nv::Device device, int threads) const
{
  const int64_t n = static_cast<int64_t>(Expected.size());
  if (n == 0)
  {
    return std::numeric_limits<double>::quiet_NaN();
  }
  std::vector<float> out(static_cast<size_t>(n));
  nv::inferPoints(model, Coords.data(), n, out.data(), device, threads);
  double se = 0.0;
  for (int64_t i = 0; i < n; ++i)
  {
    const double d = static_cast<double>(out[i]) - Expected[i];
    se += d * d;
  }
  return PsnrFromMse(se / static_cast<double>(n));
}

TrainingResult Train(nv::Model& model, const nv::VolumeView& view, const nv::TrainConfig& config,
  const TrainingRequest& request, const PsnrProbe* probe)
{
  TrainingResult result;
  const auto start = std::chrono::steady_clock::now();
  auto trainer = nv::createTrainer(request.Device, model, view, config);
  result.DeviceMemoryBytes = trainer->deviceMemoryBytes();
  double lastProgress = -1.0;
  // Steps run in chunks through Trainer::steps (queued back to back on a GPU, one loss read-back per chunk); a
  // chunk ends at the next PSNR probe and lasts at most ~20 ms on a GPU (64 steps), so abort and the time budget
  // are checked often. On the CPU a chunk is one step.
  const int64_t chunkMax = trainer->device() == nv::Device::Cuda ? 64 : 1;
  std::vector<float> losses(static_cast<size_t>(chunkMax));
  for (int64_t step = 1; step <= request.MaxSteps;)
  {
    if (request.ShouldAbort && request.ShouldAbort())
    {
      result.Aborted = true;
      break;
    }
    const double before = Seconds(start);
    if (request.TimeBudget > 0.0 && before >= request.TimeBudget)
    {
      result.TimedOut = true;
      break;
    }
    int64_t count = std::min(chunkMax, request.MaxSteps - step + 1);
    if (probe && request.PsnrInterval > 0)
      count = std::min(count, request.PsnrInterval - (step - 1) % request.PsnrInterval);
    trainer->steps(count, losses.data());
    const double after = Seconds(start);
    for (int64_t k = 0; k < count; ++k, ++step)
    {
      LogRow row;
      row.Step = step;
      row.LearningRate = config.optimizer.learningRateAt(step);
      row.Loss = losses[static_cast<size_t>(k)];
      row.ElapsedSeconds = before + (after - before) * static_cast<double>(k + 1) / static_cast<double>(count);
      row.PSNR = std::numeric_limits<double>::quiet_NaN();
      if (probe && request.PsnrInterval > 0 && step % request.PsnrInterval == 0 && step != request.MaxSteps)
      {
        trainer->syncTo(model);
        row.PSNR = probe->Estimate(model, request.Device, request.Threads);
      }
      result.Log.push_back(row);
      result.Steps = step;
      result.FinalLoss = row.Loss;
    }
    if (request.Progress)
    {
      const double elapsed = Seconds(start);
      double fraction = static_cast<double>(step - 1) / static_cast<double>(request.MaxSteps);
      if (request.TimeBudget > 0.0)
      {
        fraction = std::max(fraction, elapsed / request.TimeBudget);
      }
      fraction = std::min(fraction, 1.0);
      if (fraction - lastProgress >= 0.01)
      {
        request.Progress(fraction);
        lastProgress = fraction;
      }
    }
  }
  trainer->syncTo(model);
  result.Seconds = Seconds(start);
  return result;
}

} // namespace vtkNeuralCompressInternals
