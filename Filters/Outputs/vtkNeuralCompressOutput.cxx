#include "vtkNeuralCompressOutput.h"

#include "vtkNeuralNetworkArray.h"
#include "vtkNeuralOutOfCoreInput.h"

#include "vtkBase64Utilities.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkStringArray.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkTable.h"
#include "vtkTypeInt64Array.h"

#include <algorithm>
#include <cmath>
#include <cinttypes>
#include <cstdio>
#include <sstream>

namespace vtkNeuralCompressInternals
{
namespace
{
template <typename ArrayT, typename ValueT>
void AddFieldValue(vtkFieldData* fd, const char* name, ValueT value)
{
  vtkNew<ArrayT> a;
  a->SetName(name);
  a->SetNumberOfTuples(1);
  a->SetValue(0, value);
  fd->AddArray(a);
}

void AddString(vtkFieldData* fd, const char* name, const std::string& value)
{
  vtkNew<vtkStringArray> a;
  a->SetName(name);
  a->InsertNextValue(value);
  fd->AddArray(a);
}

std::string FormatBytes(double bytes)
{
  std::ostringstream s;
  s.precision(3);
  if (bytes >= 1024.0 * 1024.0)
    s << bytes / (1024.0 * 1024.0) << " MiB";
  else if (bytes >= 1024.0)
    s << bytes / 1024.0 << " KiB";
  else
    s << bytes << " B";
  return s.str();
}
/// What this process read from an out-of-core file so far (every pass, the block buffer, the probe): the bytes
/// (NeuralFileBytesRead; the block buffer's replacements re-read blocks, so it grows with training) and the box of
/// every sample read, in the file's sample indices (NeuralFileReadBox: xmin xmax ymin ymax zmin zmax; under MPI the
/// rank's padded piece), with its bytes (NeuralFileReadBoxBytes) against the file's (NeuralFileBytes).
void AddFileReads(vtkFieldData* fd, const nv::VolumeFileLayout& layout)
{
  if (!layout.readTally)
    return;
  AddFieldValue<vtkTypeInt64Array>(fd, "NeuralFileBytesRead", layout.readTally->bytes());
  AddFieldValue<vtkTypeInt64Array>(fd, "NeuralFileBytes", layout.fileBytes());
  int64_t lo[3], hi[3];
  if (!layout.readTally->box(lo, hi))
    return;
  vtkNew<vtkTypeInt64Array> box;
  box->SetName("NeuralFileReadBox");
  box->SetNumberOfTuples(6);
  int64_t bytes = static_cast<int64_t>(nv::scalarSize(layout.type));
  for (int a = 0; a < 3; ++a)
  {
    box->SetValue(2 * a, lo[a]);
    box->SetValue(2 * a + 1, hi[a]);
    bytes *= hi[a] - lo[a] + 1;
  }
  fd->AddArray(box);
  AddFieldValue<vtkTypeInt64Array>(fd, "NeuralFileReadBoxBytes", bytes);
}
} // namespace

void FillImage(vtkImageData* output, const FieldInfo& field, const NetworkRecord& record, vtkDataArray* decoded,
  const std::shared_ptr<nv::NetworkSession>& session, bool live)
{
  const OutputGeometry& g = field.Geometry;
  int extent[6];
  std::copy(g.Extent, g.Extent + 6, extent);
  output->SetExtent(extent);
  output->SetOrigin(g.Origin);
  output->SetSpacing(g.Spacing);
  output->SetDirectionMatrix(field.Direction);
  if (decoded)
  {
    if (field.Cells)
      output->GetCellData()->SetScalars(decoded);
    else
      output->GetPointData()->SetScalars(decoded);
  }
  vtkFieldData* fd = output->GetFieldData();
  if (HasBytes(record.Bytes))
    vtkNeuralNetworkArray::Write(fd, record.Bytes, session, live);
  const Metrics& m = record.Figures;
  AddFieldValue<vtkDoubleArray>(fd, "NeuralTrainingSeconds", m.Seconds);
  AddFieldValue<vtkTypeInt64Array>(fd, "NeuralSteps", m.Steps);
  AddFieldValue<vtkDoubleArray>(fd, "NeuralPSNR", m.Psnr);
  AddFieldValue<vtkDoubleArray>(fd, "NeuralMaxError", m.MaxError);
  AddFieldValue<vtkDoubleArray>(fd, "NeuralMaxErrorOfRange", m.MaxErrorOfRange); // finite where MaxError overflows
  if (m.SourceSamples > 0)
  {
    // A resampled input: NeuralPSNR and NeuralMaxError are at the source's own samples.
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralSourceSamples", m.SourceSamples);
    AddFieldValue<vtkDoubleArray>(fd, "NeuralResampledPSNR", m.ResampledPsnr);
  }
  if (field.OutOfCore)
  {
    // An out-of-core input: 1 once NeuralPSNR and NeuralMaxError are measured over every voxel of the file, 0 for
    // the estimate (on random rows of the file) while training.
    AddFieldValue<vtkIntArray>(fd, "NeuralPSNRExact", m.PsnrFinal ? 1 : 0);
    // The phases around training (NaN until run): the value-range pass, the block buffer's first fill, the last exact
    // pass over the file.
    AddFieldValue<vtkDoubleArray>(fd, "NeuralValueRangeSeconds", field.OutOfCore->ValueRangeSeconds.load());
    AddFieldValue<vtkDoubleArray>(fd, "NeuralFirstFillSeconds", field.OutOfCore->FirstFillSeconds.load());
    AddFieldValue<vtkDoubleArray>(fd, "NeuralExactPassSeconds", field.OutOfCore->ExactPassSeconds.load());
    AddFileReads(fd, field.OutOfCore->Layout);
    // The block buffer's reads (-1 until it exists): the bytes its blocks hold, the bytes taken from the file (whole
    // pages with BypassPageCache), those of the first fill, the swaps asked for while no block was ready.
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralBufferBytesRead", field.OutOfCore->BufferBytesRead.load());
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralBufferBytesTransferred", field.OutOfCore->BufferBytesTransferred.load());
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralBufferFirstFillBytes", field.OutOfCore->BufferFirstFillBytes.load());
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralBufferSwapsMissed", field.OutOfCore->BufferSwapsMissed.load());
  }
  AddFieldValue<vtkDoubleArray>(fd, "NeuralCompressionRatio", m.Ratio);
  if (m.ErrorBound > 0.0)
  {
    // The error-bounded mode: the bound and the samples stored with a correction (their bytes are in the ratio).
    AddFieldValue<vtkDoubleArray>(fd, "NeuralErrorBound", m.ErrorBound);
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralCorrections", m.Corrections);
  }
  AddFieldValue<vtkTypeInt64Array>(fd, "NeuralModelBytes", m.ModelBytes);
  AddFieldValue<vtkTypeInt64Array>(fd, "NeuralInvalidSamples", m.Invalid);
  AddFieldValue<vtkTypeInt64Array>(fd, "NeuralGpuMemoryBytes", m.DeviceMemoryBytes);
  AddFieldValue<vtkIntArray>(fd, "NeuralWarmStart", m.WarmStart ? 1 : 0);
  AddFieldValue<vtkIntArray>(fd, "NeuralRestored", m.Restored ? 1 : 0);
  AddFieldValue<vtkDoubleArray>(fd, "NeuralTime", record.Time);
  AddFieldValue<vtkIntArray>(fd, "NeuralSourceType", field.VtkType); // "Decoded, input type" from a saved network
  AddString(fd, "NeuralDevice", m.Device);
  AddFieldValue<vtkIntArray>(fd, "NeuralCudaDevice", m.CudaDevice);
  AddString(fd, "NeuralTrainingState", m.State);
  // The field's range: the colour and opacity maps fit it when no decoded array is output.
  vtkNew<vtkDoubleArray> range;
  range->SetName("NeuralValueRange");
  range->SetNumberOfTuples(2);
  range->SetValue(0, field.Stats.min);
  range->SetValue(1, field.Stats.max);
  fd->AddArray(range);
  // What the network represents: the Neural Volume representation shows its range under this name (so that
  // ParaView's colour-map rescaling finds the network's array on an output without a decoded field).
  AddString(fd, "NeuralArrayName", field.Name);
  AddFieldValue<vtkIntArray>(fd, "NeuralArrayAssociation", field.Cells ? 1 : 0);
}

void InitializeLog(vtkTable* log)
{
  log->Initialize();
  for (const char* name : { "Step", "Loss", "LearningRate", "ElapsedSeconds", "PSNR" })
  {
    vtkNew<vtkDoubleArray> column;
    column->SetName(name);
    log->AddColumn(column);
  }
}

void FillLog(vtkTable* log, const NetworkRecord& record)
{
  InitializeLog(log);
  // A line needs two points: a log of one row (the first publish of a run) stays empty, so that the training chart
  // draws nothing instead of failing ("Attempted to paint a line with <2 points").
  const vtkIdType rows = record.Log.size() >= 2 ? static_cast<vtkIdType>(record.Log.size()) : 0;
  log->SetNumberOfRows(rows);
  for (vtkIdType r = 0; r < rows; ++r)
  {
    const LogRow& row = record.Log[static_cast<size_t>(r)];
    const double psnr = r == rows - 1 && record.Figures.PsnrFinal ? record.Figures.Psnr : row.PSNR;
    const double values[5] = { static_cast<double>(row.Step), row.Loss, row.LearningRate, row.ElapsedSeconds, psnr };
    for (int c = 0; c < 5; ++c)
    {
      vtkDoubleArray::SafeDownCast(log->GetColumn(c))->SetValue(r, values[c]);
    }
  }
}

void InitializeMetrics(vtkTable* metrics)
{
  metrics->Initialize();
  for (const char* name : { "Time", "Steps", "Seconds", "PSNR", "MaxError", "CompressionRatio", "ModelBytes",
         "WarmStart", "Restored" })
  {
    vtkNew<vtkDoubleArray> column;
    column->SetName(name);
    metrics->AddColumn(column);
  }
  vtkNew<vtkStringArray> state;
  state->SetName("State");
  metrics->AddColumn(state);
}

void FillMetrics(vtkTable* metrics, const std::vector<const NetworkRecord*>& records)
{
  InitializeMetrics(metrics);
  std::vector<const NetworkRecord*> sorted = records;
  std::sort(sorted.begin(), sorted.end(),
    [](const NetworkRecord* a, const NetworkRecord* b) { return a->Time < b->Time; });
  metrics->SetNumberOfRows(static_cast<vtkIdType>(sorted.size()));
  for (vtkIdType r = 0; r < static_cast<vtkIdType>(sorted.size()); ++r)
  {
    const NetworkRecord& rec = *sorted[static_cast<size_t>(r)];
    const Metrics& m = rec.Figures;
    const double values[9] = { rec.Time, static_cast<double>(m.Steps), m.Seconds, m.Psnr, m.MaxError, m.Ratio,
      static_cast<double>(m.ModelBytes), m.WarmStart ? 1.0 : 0.0, m.Restored ? 1.0 : 0.0 };
    for (int c = 0; c < 9; ++c)
    {
      vtkDoubleArray::SafeDownCast(metrics->GetColumn(c))->SetValue(r, values[c]);
    }
    vtkStringArray::SafeDownCast(metrics->GetColumn(9))->SetValue(r, m.State);
  }
}

bool UntrainedByRequest(const FieldInfo& field, const Metrics& m)
{
  // Job::FinalizeWithoutTraining serves both: a field that is not constant got no step because none was asked.
  return m.EndReason == "constant field" && field.Stats.max > field.Stats.min;
}

std::string EndReasonText(const FieldInfo& field, const Metrics& m)
{
  if (UntrainedByRequest(field, m))
  {
    // Job::FinalizeWithoutTraining serves both: a field that is not constant got no step because none was asked.
    return "Training Steps is 0: the network is untrained (" + std::string(m.WarmStart ? "the warm start's" : "its random") +
      " initialisation)";
  }
  return m.EndReason;
}

bool MaxErrorOverflows(const Metrics& m)
{
  return std::isinf(m.MaxError) && std::isfinite(m.Psnr) && std::isfinite(m.MaxErrorOfRange);
}

std::string MaxErrorText(const FieldInfo& field, const Metrics& m)
{
  std::ostringstream s;
  s.precision(4);
  if (!MaxErrorOverflows(m))
  {
    s << m.MaxError;
    return s.str();
  }
  // Beyond the largest double in source units (a range wider than it): in extended precision, and of the range.
  const long double error =
    static_cast<long double>(m.MaxErrorOfRange) * (static_cast<long double>(field.Stats.max) - field.Stats.min);
  s << error << " (" << m.MaxErrorOfRange << " of the range, above the largest double)";
  return s.str();
}

std::string SpacingAdvice(const double spacing[3], const int64_t dims[3])
{
  std::string zero;
  bool negative = false;
  for (int a = 0; a < 3; ++a)
  {
    if (spacing[a] == 0.0 && dims[a] > 1)
      zero += std::string(zero.empty() ? "" : ", ") + "xyz"[a];
    negative = negative || spacing[a] < 0.0;
  }
  if (!zero.empty())
    return "The image has zero spacing on axis " + zero + ": set a positive spacing where the image is made (e.g. " +
      "the reader's Data Spacing) or with a Programmable Filter (output.ShallowCopy(inputs[0].VTKObject); " +
      "output.SetSpacing(1, 1, 1))";
  if (negative)
    return "Flip an image with negative spacing first (e.g. Filters > Transform with a negative scale and Resample "
           "With Dataset)";
  return "The image's origin and spacing must be finite";
}

std::string SmallerModelAdvice(const Job& job)
{
  const nv::ModelConfig& config = job.NetworkConfig;
  std::string advice;
  if (config.encoding.log2TableSize > 10)
    advice += ", a smaller Log2 Table Size (2^" + std::to_string(config.encoding.log2TableSize) + " now)";
  if (config.encoding.levels > 8)
    advice += ", fewer Levels (" + std::to_string(config.encoding.levels) + ")";
  if (config.encoding.featuresPerLevel > 1)
    advice += ", fewer Features Per Level (" + std::to_string(config.encoding.featuresPerLevel) + ")";
  if (config.network.width > 16)
    advice += ", a narrower network (Network Width " + std::to_string(config.network.width) + ")";
  if (job.Storage != nv::Precision::Quantized8)
    advice += ", 8-bit (entropy coded) storage";
  return advice.empty() ? advice : advice.substr(2);
}

std::string Summary(
  const FieldInfo& field, const Job& job, const NetworkRecord& record, double targetRatio, bool fromCache)
{
  const Metrics& m = record.Figures;
  const nv::ModelConfig& config = job.NetworkConfig;
  std::ostringstream s;
  s.precision(4);
  s << "Neural Compress: '" << field.Name << "' (" << (field.Cells ? "cell" : "point");
  if (!field.Description.empty())
    s << ", " << field.Description;
  s << ", " << field.Geometry.SourceDims[0] << "x" << field.Geometry.SourceDims[1] << "x"
    << field.Geometry.SourceDims[2];
  if (job.Time != 0.0)
    s << ", t = " << job.Time;
  s << "): ";
  if (m.Restored)
    s << "network restored from the state, no training";
  else
  {
    if (fromCache)
      s << "network of this time step taken from the cache, no training (trained before: ";
    s << m.Steps << " steps in " << m.Seconds << " s on " << m.Device;
    if (m.WarmStart)
      s << " (warm start)";
    const std::string reason = EndReasonText(field, m);
    if (!reason.empty() && reason != "step limit")
      s << " (" << reason << ")";
    if (fromCache)
      s << ")";
  }
  s << "; PSNR " << m.Psnr << " dB, max error " << MaxErrorText(field, m);
  if (m.SourceSamples > 0)
  {
    s << " at " << m.SourceSamples << " source samples";
    if (std::isfinite(m.ResampledPsnr))
      s << " (" << m.ResampledPsnr << " dB on the resampled image)";
  }
  s << "; model "
    << FormatBytes(static_cast<double>(m.ModelBytes)) << " (2^" << config.encoding.log2TableSize << " table, "
    << nv::precisionName(job.Storage) << "), ratio " << m.Ratio << ":1";
  if (SizedForPsnr(job.TrainingSettings))
    s << "; Size For PSNR " << job.TrainingSettings.SizeForPsnr << " dB "
      << (m.Psnr >= job.TrainingSettings.SizeForPsnr ? "reached" : "NOT reached");
  else if (targetRatio > 0.0)
    s << " (target " << targetRatio << ")";
  if (m.ErrorBound > 0.0)
    s << "; error bound " << m.ErrorBound << " (" << m.Corrections << " samples corrected, in the ratio)";
  if (m.Ratio < 1.0)
  {
    const std::string advice = SmallerModelAdvice(job);
    s << ". The model is larger than the field (" << FormatBytes(m.Ratio * static_cast<double>(m.ModelBytes))
      << "): a field this small is better kept as it is";
    if (!advice.empty())
      s << ", or compressed with a smaller model: " << advice;
  }
  if (!job.DeviceNote.empty())
    s << "; " << job.DeviceNote;
  if (!job.SizeNote.empty())
    s << "; " << job.SizeNote;
  s << "\n";
  return s.str();
}

std::string EncodeNetworks(const std::vector<const NetworkRecord*>& records)
{
  std::string text = "nvnet1";
  for (const NetworkRecord* r : records)
  {
    if (!r || !HasBytes(r->Bytes))
      continue;
    char key[32];
    std::snprintf(key, sizeof(key), "%016" PRIx64, r->Key);
    const NetworkBytes& bytes = r->Bytes;
    std::vector<unsigned char> b64(bytes->size() * 4 / 3 + 8);
    const unsigned long n =
      vtkBase64Utilities::Encode(bytes->data(), static_cast<unsigned long>(bytes->size()), b64.data(), 0);
    text += ";";
    text += key;
    text += ":";
    text.append(reinterpret_cast<const char*>(b64.data()), n);
  }
  return text;
}

std::map<uint64_t, std::vector<uint8_t>> DecodeNetworks(const std::string& text, std::string& error)
{
  std::map<uint64_t, std::vector<uint8_t>> out;
  if (text.empty())
    return out;
  if (text.compare(0, 6, "nvnet1") != 0)
  {
    error = "the saved networks are not in a known format (expected 'nvnet1')";
    return out;
  }
  size_t pos = 6;
  while (pos < text.size() && text[pos] == ';')
  {
    const size_t end = std::min(text.find(';', pos + 1), text.size());
    const size_t colon = text.find(':', pos + 1);
    if (colon == std::string::npos || colon >= end || colon - pos - 1 != 16)
    {
      error = "a saved network entry is malformed";
      pos = end;
      continue;
    }
    const uint64_t key = std::strtoull(text.substr(pos + 1, 16).c_str(), nullptr, 16);
    const size_t len = end - colon - 1;
    std::vector<uint8_t> bytes(len);
    const size_t n = vtkBase64Utilities::DecodeSafely(
      reinterpret_cast<const unsigned char*>(text.data() + colon + 1), len, bytes.data(), bytes.size());
    bytes.resize(n);
    out[key] = std::move(bytes);
    pos = end;
  }
  return out;
}

void InitializeOutputs(
  vtkImageData* output, vtkTable* log, vtkTable* metrics, vtkInformation* outInfo, const double* bounds)
{
  output->Initialize();
  InitializeLog(log);
  InitializeMetrics(metrics);
  if (outInfo && outInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    int ext[6];
    double origin[3] = { 0.0, 0.0, 0.0 }, spacing[3] = { 1.0, 1.0, 1.0 };
    outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext);
    if (outInfo->Has(vtkDataObject::ORIGIN()))
      outInfo->Get(vtkDataObject::ORIGIN(), origin);
    if (outInfo->Has(vtkDataObject::SPACING()))
      outInfo->Get(vtkDataObject::SPACING(), spacing);
    for (int a = 0; bounds && a < 3; ++a)
    {
      // The resampled image spans the bounds with its samples (vtkResampleToImage, UseInputBounds).
      const int cells = ext[2 * a + 1] - ext[2 * a];
      origin[a] = bounds[2 * a];
      spacing[a] = cells > 0 && bounds[2 * a + 1] > bounds[2 * a] ? (bounds[2 * a + 1] - bounds[2 * a]) / cells : 1.0;
      origin[a] -= ext[2 * a] * spacing[a];
    }
    output->SetExtent(ext);
    output->SetOrigin(origin);
    output->SetSpacing(spacing);
  }
}

void InitializePreparingOutputs(
  vtkImageData* output, vtkTable* log, vtkTable* metrics, vtkInformation* outInfo, const double* bounds)
{
  InitializeOutputs(output, log, metrics, outInfo, bounds);
  AddString(output->GetFieldData(), "NeuralTrainingState", "Preparing");
}

} // namespace vtkNeuralCompressInternals
