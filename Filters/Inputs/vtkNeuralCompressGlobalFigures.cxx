// The whole field's figures from every rank's sums (vtkNeuralCompressGlobalFigures.h).
#include "vtkNeuralCompressGlobalFigures.h"

#include "vtkNeuralCompressDistributed.h"

#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "Core/ValueRange.h"
#include "Core/Volume.h"

#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkIntArray.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkTable.h"
#include "vtkTypeInt64Array.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace vtkNeuralCompressInternals
{
namespace
{
/// The sample indices (point or cell, in extent units) axis `a` of `owned` holds exclusively.
void ExclusiveRange(const int owned[6], const int whole[6], bool cells, int a, int& lo, int& hi)
{
  lo = owned[2 * a];
  hi = owned[2 * a + 1];
  const bool flat = owned[2 * a] == owned[2 * a + 1];
  if (flat)
    return; // one plane of points (or a flat layer of cells)
  // Points: the shared upper plane belongs to the next piece, except the whole extent's last one. Cells: the
  // piece's cells.
  if (cells || hi < whole[2 * a + 1])
    hi -= 1;
}

/// Samples of the whole extent and those `owned` holds exclusively (a sample count, points or cells).
void CountSamples(const int owned[6], const int whole[6], bool cells, double& samples, double& wholeSamples)
{
  samples = wholeSamples = 1.0;
  for (int a = 0; a < 3; ++a)
  {
    int lo = 0, hi = 0;
    ExclusiveRange(owned, whole, cells, a, lo, hi);
    const int points = whole[2 * a + 1] - whole[2 * a] + 1;
    wholeSamples *= cells ? std::max(points - 1, 1) : points;
    samples *= std::max(hi - lo + 1, 0);
  }
}

template <typename ArrayT>
void SetValue(vtkFieldData* fd, const char* name, double value)
{
  vtkNew<ArrayT> array;
  array->SetName(name);
  array->SetNumberOfTuples(1);
  array->SetTuple1(0, value);
  fd->AddArray(array); // replaces the array of that name
}
} // namespace

//------------------------------------------------------------------------------
bool ExclusiveSamples(const int trainExtent[6], const int64_t dims[3], const int owned[6], const int whole[6],
  bool cells, int lo[3], int hi[3], double& samples, double& wholeSamples)
{
  samples = wholeSamples = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    ExclusiveRange(owned, whole, cells, a, lo[a], hi[a]);
    lo[a] = std::max(lo[a] - trainExtent[2 * a], 0);
    hi[a] = static_cast<int>(std::min<int64_t>(hi[a] - trainExtent[2 * a], dims[a] - 1));
    if (lo[a] > hi[a])
      return false;
  }
  samples = wholeSamples = 1.0;
  for (int a = 0; a < 3; ++a)
  {
    const int points = whole[2 * a + 1] - whole[2 * a] + 1;
    wholeSamples *= cells ? std::max(points - 1, 1) : points;
    samples *= hi[a] - lo[a] + 1;
  }
  return true;
}

PieceSums SumsOfMeasurement(const nv::ErrorStats& error, double valueMin, double valueMax, double samples,
  double wholeSamples, double rawBytesPerSample, double modelBytes)
{
  PieceSums sums;
  sums.Samples = samples;
  sums.WholeSamples = wholeSamples;
  sums.Count = static_cast<double>(error.count);
  sums.NonFinite = static_cast<double>(error.nonFinite);
  sums.ValueMin = valueMin;
  sums.ValueMax = valueMax;
  // The error's mse is normalised by the network's range where it spans one (FileMeasure.cpp), in source units else.
  const nv::ValueRange range(valueMin, valueMax);
  const double unit = range.spans() ? range.span(1.0) : 1.0;
  if (error.nonFinite == 0 && std::isfinite(error.mse))
    sums.SquaredError = error.mse * sums.Count * unit * unit;
  sums.MaxError = error.nonFinite == 0 ? error.maxAbsError : 0.0;
  sums.FieldBytes = sums.Count * rawBytesPerSample;
  sums.ModelBytes = modelBytes;
  sums.Networks = 1.0;
  return sums;
}

PieceSums MeasurePiece(nv::NetworkSession& session, const nv::VolumeView& view, const int trainExtent[6],
  const int owned[6], const int whole[6], bool cells, double rawBytesPerSample, double modelBytes)
{
  PieceSums sums;
  int lo[3], hi[3];
  double samples = 0.0, wholeSamples = 0.0;
  if (!ExclusiveSamples(trainExtent, view.dims, owned, whole, cells, lo, hi, samples, wholeSamples))
    return sums;
  sums.Samples = samples;
  sums.WholeSamples = wholeSamples;
  const int64_t nx = view.dims[0], ny = view.dims[1], nz = view.dims[2];
  std::vector<double> slab(static_cast<size_t>(nx * ny));
  sums.ValueMin = std::numeric_limits<double>::infinity();
  sums.ValueMax = -std::numeric_limits<double>::infinity();
  for (int64_t z = lo[2]; z <= hi[2]; ++z)
  {
    nv::decodeGridValues(session, nx, ny, nz, z, z + 1, slab.data());
    for (int64_t y = lo[1]; y <= hi[1]; ++y)
      for (int64_t x = lo[0]; x <= hi[0]; ++x)
      {
        const double source = view.at(x + nx * (y + ny * z));
        if (!std::isfinite(source))
          continue;
        const double decoded = slab[static_cast<size_t>(x + nx * y)];
        sums.Count += 1.0;
        sums.ValueMin = std::min(sums.ValueMin, source);
        sums.ValueMax = std::max(sums.ValueMax, source);
        if (!std::isfinite(decoded))
        {
          sums.NonFinite += 1.0;
          continue;
        }
        const double e = decoded - source;
        sums.SquaredError += e * e;
        sums.MaxError = std::max(sums.MaxError, std::fabs(e));
      }
  }
  sums.FieldBytes = sums.Count * rawBytesPerSample;
  sums.ModelBytes = modelBytes;
  sums.Networks = 1.0;
  return sums;
}

PieceSums EstimatePiece(const int owned[6], const int whole[6], bool cells, double psnr, double valueMin,
  double valueMax, double rawBytesPerSample, double modelBytes)
{
  PieceSums sums;
  CountSamples(owned, whole, cells, sums.Samples, sums.WholeSamples);
  sums.Estimated = 1.0;
  sums.Networks = modelBytes > 0.0 ? 1.0 : 0.0;
  sums.ModelBytes = modelBytes;
  sums.Count = sums.Samples;
  sums.FieldBytes = sums.Count * rawBytesPerSample;
  sums.ValueMin = valueMin;
  sums.ValueMax = valueMax;
  const double span = valueMax > valueMin ? valueMax - valueMin : 1.0;
  if (std::isfinite(psnr))
    sums.SquaredError = sums.Count * span * span * std::pow(10.0, -psnr / 10.0);
  else
    sums.Unknown = 1.0;
  return sums;
}

GlobalFigures ReduceFigures(const PieceSums& local)
{
  GlobalFigures g;
  vtkMultiProcessController* c = DistributedController();
  const bool have = local.Count > 0.0;
  // Sums, then maxima (min as the max of the negated value).
  double sum[10] = { local.SquaredError, local.Count, local.NonFinite, local.ModelBytes, local.FieldBytes,
    local.Networks, local.Samples, local.Failed, local.Estimated, local.Unknown };
  double max[4] = { local.MaxError, have ? local.ValueMax : -std::numeric_limits<double>::max(),
    have ? -local.ValueMin : -std::numeric_limits<double>::max(), local.WholeSamples };
  double sumAll[10], maxAll[4];
  std::copy(sum, sum + 10, sumAll);
  std::copy(max, max + 4, maxAll);
  if (c)
  {
    c->AllReduce(sum, sumAll, 10, vtkCommunicator::SUM_OP);
    c->AllReduce(max, maxAll, 4, vtkCommunicator::MAX_OP);
  }
  g.Samples = sumAll[6];
  g.Failed = static_cast<int>(sumAll[7]);
  g.WholeSamples = maxAll[3];
  g.Count = sumAll[1];
  g.ModelBytes = sumAll[3];
  g.Networks = static_cast<int>(sumAll[5]);
  const double span = maxAll[1] + maxAll[2]; // max - min of the whole field
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(g.Count > 0.0))
  {
    g.Psnr = g.MaxError = g.MaxErrorOfRange = nan;
    return g;
  }
  const bool diverged = sumAll[2] > 0.0;
  g.MaxError = diverged ? std::numeric_limits<double>::infinity() : maxAll[0];
  g.MaxErrorOfRange = span > 0.0 ? g.MaxError / span : g.MaxError;
  const double scale = span > 0.0 ? span * span : 1.0;
  const double pieceMse = local.Count > 0.0 ? local.SquaredError / local.Count / scale : nan;
  g.PiecePsnr = pieceMse > 0.0 ? 10.0 * std::log10(1.0 / pieceMse) : (pieceMse == 0.0 ? HUGE_VAL : nan);
  const double mse = sumAll[0] / g.Count / scale;
  g.Psnr = diverged ? nan : (mse > 0.0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity());
  g.Estimated = sumAll[8] > 0.0;
  if (g.Estimated)
  {
    // Live figures: the estimates of the ranks that train, the exact sums of those done; no max error yet.
    g.MaxError = g.MaxErrorOfRange = nan;
    if (sumAll[9] > 0.0)
      g.Psnr = nan;
    if (local.Unknown > 0.0)
      g.PiecePsnr = nan;
  }
  g.Ratio = g.ModelBytes > 0.0 ? sumAll[4] / g.ModelBytes : 0.0;
  return g;
}

void WriteGlobalFigures(vtkImageData* output, vtkTable* metrics, const GlobalFigures& global)
{
  if (!output)
    return;
  vtkFieldData* fd = output->GetFieldData();
  vtkDataArray* time = fd->GetArray("NeuralTime");
  SetValue<vtkDoubleArray>(fd, "NeuralPSNR", global.Psnr);
  SetValue<vtkDoubleArray>(fd, "NeuralMaxError", global.MaxError);
  SetValue<vtkDoubleArray>(fd, "NeuralMaxErrorOfRange", global.MaxErrorOfRange);
  SetValue<vtkDoubleArray>(fd, "NeuralCompressionRatio", global.Ratio);
  SetValue<vtkTypeInt64Array>(fd, "NeuralModelBytes", global.ModelBytes);
  SetValue<vtkDoubleArray>(fd, "NeuralPiecePSNR", global.PiecePsnr);
  SetValue<vtkIntArray>(fd, "NeuralNetworks", global.Networks);
  if (!metrics || !time || metrics->GetNumberOfColumns() < 7)
    return;
  for (vtkIdType r = 0; r < metrics->GetNumberOfRows(); ++r)
  {
    if (metrics->GetValue(r, 0).ToDouble() != time->GetTuple1(0))
      continue;
    const double values[4] = { global.Psnr, global.MaxError, global.Ratio, global.ModelBytes };
    for (int c = 3; c < 7; ++c)
      vtkDoubleArray::SafeDownCast(metrics->GetColumn(c))->SetValue(r, values[c - 3]);
  }
}

} // namespace vtkNeuralCompressInternals
