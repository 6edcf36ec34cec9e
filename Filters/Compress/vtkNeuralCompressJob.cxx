#include "vtkNeuralCompressJob.h"

#include "vtkNeuralCompressDecode.h"

#include "vtkNeuralCompress.h"

#include "Core/Error.h"
#include "Core/Macrocells.h"
#include "Core/Serialization.h"
#include "Core/ValueRange.h"

#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkType.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <system_error>
#include <thread>

namespace vtkNeuralCompressInternals
{
namespace
{
uint64_t Fnv(uint64_t h, const void* data, size_t size)
{
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i)
  {
    h = (h ^ p[i]) * 1099511628211ull;
  }
  return h;
}

} // namespace

bool SameDecodedGrid(const OutputGeometry& a, const OutputGeometry& b)
{
  return std::equal(a.DecodedDims, a.DecodedDims + 3, b.DecodedDims) && std::equal(a.Extent, a.Extent + 6, b.Extent) &&
    std::equal(a.Origin, a.Origin + 3, b.Origin) && std::equal(a.Spacing, a.Spacing + 3, b.Spacing) &&
    a.OnSourceGrid == b.OnSourceGrid;
}

OutputGeometry OutputGeometryOf(
  const FieldInfo& field, const int outputResolution[3], int finestResolution, int baseResolution)
{
  const bool automatic =
    std::all_of(outputResolution, outputResolution + 3, [](int r) { return r <= 0; }) && field.CoarsenedDims[0] > 0;
  const int* resolution = automatic ? field.CoarsenedDims : outputResolution;
  const bool sourceGrid = std::all_of(resolution, resolution + 3, [](int r) { return r <= 0; });
  if (field.PieceWhole[1] < field.PieceWhole[0] || automatic || sourceGrid)
    return ComputeGeometry(field.InputExtent, field.InputOrigin, field.InputSpacing, field.Cells, resolution,
      finestResolution, baseResolution);
  // MPI: every rank's output is its part of one lattice over the whole extent.
  const OutputGeometry whole = ComputeGeometry(field.PieceWhole, field.InputOrigin, field.InputSpacing, field.Cells,
    resolution, finestResolution, baseResolution);
  return PieceOfWholeGeometry(
    whole, field.InputExtent, field.PieceOwned, field.PieceWhole, field.InputOrigin, field.InputSpacing, field.Cells);
}

bool Float32Holds(double lo, double hi)
{
  const double m = std::max(std::fabs(lo), std::fabs(hi));
  const nv::ValueRange range(lo, hi);
  if (!(m <= double(std::numeric_limits<float>::max())))
    return false; // also every range wider than the largest double
  if (m > 0.0 && m < double(std::numeric_limits<float>::min()))
    return false; // subnormal or flushed to 0 in float32
  // float32's spacing at the largest magnitude (2^-23 relative) within 1e-4 of the range: 80 dB of rounding noise,
  // below any network's error.
  return !range.spans() || m * std::ldexp(1.0, -23) <= 1e-4 * range.width();
}

uint64_t TrainingKey(const nv::VolumeView& view, const FieldInfo& field, const Settings& s)
{
  uint64_t h = 1469598103934665603ull;
  const std::string settings = s.Canonical();
  h = Fnv(h, settings.data(), settings.size());
  h = Fnv(h, field.Name.data(), field.Name.size());
  h = Fnv(h, &field.Cells, sizeof(field.Cells));
  h = Fnv(h, &field.VtkType, sizeof(field.VtkType));
  h = Fnv(h, view.dims, sizeof(view.dims));
  // The input's geometry (the output's at OutputResolution 0 0 0, as keys of saved states hold it): the output
  // resolution decides no training.
  h = Fnv(h, field.InputOrigin, sizeof(field.InputOrigin));
  h = Fnv(h, field.InputSpacing, sizeof(field.InputSpacing));
  h = Fnv(h, field.InputExtent, sizeof(field.InputExtent));
  h = Fnv(h, field.Direction, sizeof(field.Direction));
  const int type = static_cast<int>(view.type);
  h = Fnv(h, &type, sizeof(type));
  // The values: CRC-32 over blocks of 1 MiB, folded in in order (every byte counts). The blocks' CRCs are
  // independent: large fields compute them on several threads (the key is the same for any split).
  const auto* bytes = static_cast<const uint8_t*>(view.data);
  const int64_t total = view.bytes();
  const int64_t block = int64_t(1) << 20;
  const int64_t blocks = (total + block - 1) / block;
  std::vector<uint32_t> crcs(static_cast<size_t>(blocks));
  auto crcOf = [&](int64_t b, int64_t e) {
    for (int64_t k = b; k < e; ++k)
    {
      const int64_t off = k * block;
      crcs[size_t(k)] = nv::crc32(bytes + off, static_cast<size_t>(std::min<int64_t>(block, total - off)));
    }
  };
  const int parts = static_cast<int>(std::max<int64_t>(1,
    std::min<int64_t>(std::min<int64_t>(8, std::max<unsigned>(1u, std::thread::hardware_concurrency())), blocks / 4)));
  std::vector<std::thread> threads;
  for (int t = 1; t < parts; ++t)
    try
    {
      threads.emplace_back(crcOf, blocks * t / parts, blocks * (t + 1) / parts);
    }
    catch (const std::system_error&) // no thread to be had (a process limit): this part here
    {
      crcOf(blocks * t / parts, blocks * (t + 1) / parts);
    }
  crcOf(0, blocks / parts);
  for (std::thread& t : threads)
    t.join();
  for (const uint32_t c : crcs)
  {
    h = Fnv(h, &c, sizeof(c));
  }
  return h;
}

/// Error of the network at the source's own samples of a resampled input, values normalised by [lo, hi] as in
/// training. A non-finite network value counts as an infinite error (the PSNR is then -inf, never a good number).
static nv::ErrorStats SourceError(
  nv::NetworkSession& session, const nv::Model& model, const SourceSamples& s, double lo, double hi)
{
  nv::ErrorStats e;
  const size_t n = s.Values.size();
  if (n == 0)
  {
    e.psnr = std::numeric_limits<double>::quiet_NaN();
    return e;
  }
  std::vector<float> xyz(3 * n), out(n);
  const double* b = model.source.bounds;
  for (size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a)
    {
      const double len = b[2 * a + 1] - b[2 * a];
      const double u = len > 0.0 ? (s.Xyz[3 * i + size_t(a)] - b[2 * a]) / len : 0.5;
      xyz[3 * i + size_t(a)] = static_cast<float>(std::min(1.0, std::max(0.0, u)));
    }
  session.inferPoints(xyz.data(), static_cast<int64_t>(n), out.data(), nv::Memory::Host);
  // Errors in units of the range (a constant field: in source units), as nv::compareDecoded measures them: the
  // difference of the normalised values stays finite for every range (ValueRange.h).
  const nv::ValueRange range(lo, hi);
  double se = 0.0;
  for (size_t i = 0; i < n; ++i)
  {
    const double src = s.Values[i];
    if (!std::isfinite(src))
      continue; // NaN / Inf source samples are not trained on (counted as invalid elsewhere)
    const double v = model.denormalize(static_cast<double>(out[i]));
    ++e.count;
    if (!std::isfinite(v))
    {
      ++e.nonFinite; // a diverged network: never a score (see nv::ErrorStats)
      continue;
    }
    const double dn = range.spans() ? range.normalize(v) - range.normalize(src) : v - src;
    se += dn * dn;
    e.maxAbsError = std::max(e.maxAbsError, std::fabs(range.spans() ? range.span(dn) : dn));
    e.maxErrorOfRange = std::max(e.maxErrorOfRange, std::fabs(dn));
  }
  if (e.nonFinite > 0)
  {
    e.mse = e.psnr = std::numeric_limits<double>::quiet_NaN();
    e.maxAbsError = e.maxErrorOfRange = std::numeric_limits<double>::infinity();
    return e;
  }
  e.mse = e.count > 0 ? se / double(e.count) : 0.0;
  e.psnr = e.count == 0 ? std::numeric_limits<double>::quiet_NaN()
    : e.mse > 0.0       ? 10.0 * std::log10(1.0 / e.mse)
                        : std::numeric_limits<double>::infinity();
  return e;
}

/// The error of the phase's network: of its decoded output as it is (on the source's grid), else of the network on the
/// source's grid; a resampled input's at its own samples (`resampledPsnr`: the one on the resampled image).
static nv::ErrorStats MeasureNetwork(nv::NetworkSession& session, const nv::Model& model, const nv::VolumeView& view,
  const FieldInfo& field, vtkDataArray* decoded, int threads, double& resampledPsnr, int64_t& sourceSamples)
{
  nv::ErrorStats error;
  if (!view.data)
  {
    // A sparse input (vtkNeuralCompressSparse.h) has no dense field: it is measured at its samples below.
  }
  else if (decoded && field.Geometry.OnSourceGrid)
  {
    // The output as it is (rounded, clamped or thresholded to the input's type): the figures are the output's.
    error = CompareDecodedOutput(decoded, view, field.Stats.min, field.Stats.max, threads);
  }
  else
  {
    error = nv::compareToSource(session, view);
  }
  if (field.Samples)
  {
    // A resampled input: the error that counts is the one at the source's own samples.
    resampledPsnr = view.data ? error.psnr : std::numeric_limits<double>::quiet_NaN();
    error = SourceError(session, model, *field.Samples, field.Stats.min, field.Stats.max);
    sourceSamples = error.count;
  }
  return error;
}

Metrics MetricsOf(const nv::Model& model, const std::string& device)
{
  Metrics m;
  m.Steps = model.stats.steps;
  m.Seconds = model.stats.seconds;
  m.Psnr = model.stats.psnr;
  m.PsnrFinal = true;
  m.MaxError = model.stats.maxError;
  // Not stored with the network: from the max error (unknown where that overflowed to inf in a finite PSNR).
  const nv::ValueRange range(model.source.valueMin, model.source.valueMax);
  m.MaxErrorOfRange = std::isinf(m.MaxError) && std::isfinite(m.Psnr) ? std::numeric_limits<double>::quiet_NaN()
    : range.spans()                                                  ? range.perWidth(m.MaxError)
                                                                     : m.MaxError;
  m.ModelBytes = model.storedBytes();
  m.Ratio = static_cast<double>(model.source.rawBytes) / static_cast<double>(std::max<int64_t>(m.ModelBytes, 1));
  m.ErrorBound = model.corrections.bound;
  m.Corrections = model.corrections.count();
  m.Invalid = model.stats.invalidSamples;
  m.Device = device;
  return m;
}

//------------------------------------------------------------------------------
std::shared_ptr<const NetworkRecord> Job::Final() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->FinalRecord;
}

vtkSmartPointer<vtkDataArray> Job::FinalDecoded(int outputMode) const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->DecodedMode == outputMode ? this->Decoded : nullptr;
}

void Job::KeepDecoded(vtkSmartPointer<vtkDataArray> decoded, int outputMode)
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->Decoded = decoded;
  this->DecodedMode = outputMode;
}

bool Job::SetOutputGeometry(const OutputGeometry& geometry)
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (SameDecodedGrid(geometry, this->Field.Geometry))
    return false;
  this->Field.Geometry = geometry;
  this->Decoded = nullptr; // the network is the same; its field is decoded again on the new grid
  return true;
}

void Job::Finalize(const RunStatus& status)
{
  // The network as it is stored (fp16 or fp32) is the one shown, measured and saved.
  nv::Model model = this->Session->currentModel();
  model.quantize(this->Storage);
  model.corrections = nv::ErrorCorrections(); // computed again for these parameters (CorrectErrors)
  if (this->Retiring)
  {
    this->KeepInterruptedNetwork(model, status);
    return;
  }
  this->Session->setModel(model);
  const std::string boundNote = this->CorrectErrors(model);
  int mode = 0;
  FieldInfo field; // a copy: the filter's thread may change the output geometry meanwhile (SetOutputGeometry)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    mode = this->OutputMode;
    field = this->Field;
  }
  // An abort that ended the training asked for the network of the moment, not for no field: only one raised
  // during the decode stops it.
  const bool abortedBefore = this->DecodeAbort && this->DecodeAbort();
  std::string decodeError;
  vtkSmartPointer<vtkDataArray> decoded = this->DecodeAtPhaseEnd(field, mode, abortedBefore, decodeError);
  PhaseMeasurement measured;
  if (field.OutOfCore)
    measured = this->MeasureOutOfCoreFile(field, status, abortedBefore);
  else
    measured.Error = MeasureNetwork(*this->Session, model, this->Data->Field.View, field, decoded,
      this->TrainingSettings.Threads, measured.ResampledPsnr, measured.SourceSamples);
  std::shared_ptr<NetworkRecord> record = this->MeasuredRecord(model, status, measured, abortedBefore);
  record->Figures.ErrorBoundNote = boundNote;
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->FinalRecord = record;
  // A field decoded for a geometry that changed meanwhile is not the output's (decoded again on demand).
  this->Decoded = SameDecodedGrid(field.Geometry, this->Field.Geometry) ? decoded : nullptr;
  this->DecodedMode = mode;
  this->DecodeError = decodeError;
}

void Job::KeepInterruptedNetwork(nv::Model& model, const RunStatus& status)
{
  // Replaced by another job: the network (for warm starts and the cache), no decode, no measurement.
  auto record = std::make_shared<NetworkRecord>();
  record->Key = this->Key;
  record->Time = this->Time;
  model.stats.steps = status.Steps;
  model.stats.seconds = status.Seconds;
  record->Bytes = ShareBytes(nv::serialize(model));
  record->Figures.State = "Interrupted";
  record->Figures.Steps = status.Steps;
  record->Figures.Seconds = status.Seconds;
  record->Figures.ModelBytes = model.parameterBytes();
  record->Figures.Device = nv::deviceName(this->Session->device());
  record->Figures.CudaDevice = this->Session->cudaDevice();
  record->Figures.WarmStart = this->WarmStart;
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->FinalRecord = record;
  this->Decoded = nullptr;
}

std::string Job::CorrectErrors(nv::Model& model)
{
  const double bound = this->TrainingSettings.MaxError;
  if (!(bound > 0.0))
    return std::string();
  const nv::VolumeView& view = this->Data->Field.View;
  const int64_t* dims = model.source.dims;
  if (this->Field.OutOfCore || this->Field.Samples || !view.data || view.dims[0] != dims[0] ||
    view.dims[1] != dims[1] || view.dims[2] != dims[2])
    return "Max Error applies to image inputs trained on their own samples; this input was resampled or streamed "
           "from a file, so the network is stored without an error bound";
  try
  {
    nv::ErrorCorrections corrections;
    corrections.bound = bound;
    const int64_t slice = dims[0] * dims[1];
    const int64_t slabs = std::max<int64_t>(1, (int64_t(1) << 22) / slice);
    std::vector<double> decoded;
    for (int64_t z0 = 0; z0 < dims[2]; z0 += slabs)
    {
      const int64_t z1 = std::min(dims[2], z0 + slabs);
      decoded.resize(static_cast<size_t>((z1 - z0) * slice));
      nv::decodeGridValues(*this->Session, dims[0], dims[1], dims[2], z0, z1, decoded.data()); // no corrections yet
      nv::appendCorrections(corrections, decoded.data(), view, z0 * slice, (z1 - z0) * slice);
    }
    model.corrections = std::move(corrections);
    this->Session->setModel(model); // the session decodes with them from now on
  }
  catch (const std::exception& e)
  {
    model.corrections = nv::ErrorCorrections();
    return std::string("the error bound could not be kept: ") + e.what();
  }
  return std::string();
}

vtkSmartPointer<vtkDataArray> Job::DecodeAtPhaseEnd(
  const FieldInfo& field, int mode, bool abortedBefore, std::string& decodeError)
{
  try
  {
    DecodeControl control;
    control.Abort = [this, abortedBefore]() {
      return this->Retiring.load() || (!abortedBefore && this->DecodeAbort && this->DecodeAbort());
    };
    control.Progress = this->DecodeProgress;
    return DecodeOutput(*this->Session, field, mode, control);
  }
  catch (const std::exception& e)
  {
    decodeError = e.what(); // the network stays; the output has no decoded field
  }
  return nullptr;
}

std::shared_ptr<NetworkRecord> Job::MeasuredRecord(
  nv::Model& model, const RunStatus& status, const PhaseMeasurement& measured, bool abortedBefore)
{
  const nv::ErrorStats& error = measured.Error;
  auto record = std::make_shared<NetworkRecord>();
  record->Key = this->Key;
  record->Time = this->Time;
  model.stats.steps = status.Steps;
  model.stats.seconds = status.Seconds;
  model.stats.finalLoss = status.Loss;
  model.stats.psnr = error.psnr;
  model.stats.maxError = error.maxAbsError;
  model.stats.invalidSamples = this->Field.Stats.invalid;
  model.stats.device = nv::deviceName(this->Session->device());
  record->Bytes = ShareBytes(nv::serialize(model));
  Metrics& m = record->Figures;
  const bool aborted = status.EndReason == "stopped" && abortedBefore; // the filter's AbortExecute, not Stop
  m.State = aborted ? "Aborted" : status.EndReason == "stopped" ? "Stopped" : "Finished";
  m.EndReason = aborted ? "aborted" : status.EndReason;
  m.Steps = status.Steps;
  m.Seconds = status.Seconds;
  m.Psnr = error.psnr;
  m.PsnrFinal = measured.Exact;
  m.MaxError = error.maxAbsError;
  m.MaxErrorOfRange = error.maxErrorOfRange;
  m.ResampledPsnr = measured.ResampledPsnr;
  m.SourceSamples = measured.SourceSamples;
  m.ModelBytes = model.storedBytes();
  m.Ratio = static_cast<double>(model.source.rawBytes) / static_cast<double>(std::max<int64_t>(m.ModelBytes, 1));
  m.ErrorBound = model.corrections.bound;
  m.Corrections = model.corrections.count();
  m.Invalid = this->Field.Stats.invalid;
  m.DeviceMemoryBytes = status.DeviceMemoryBytes;
  m.Device = nv::deviceName(this->Session->device());
  m.CudaDevice = this->Session->cudaDevice();
  m.WarmStart = this->WarmStart;
  if (this->Run)
  {
    record->Log = this->Run->log();
  }
  return record;
}

void Job::InstallInitialNetwork()
{
  nv::Model model(this->NetworkConfig);
  model.source = this->Source;
  bool warm = false;
  if (HasBytes(this->WarmSeed))
  {
    try
    {
      const nv::Model previous = nv::deserialize(this->WarmSeed->data(), this->WarmSeed->size());
      const nv::ModelConfig& was = previous.config();
      warm = previous.params().size() == model.params().size() &&
        was.encoding.log2TableSize == this->NetworkConfig.encoding.log2TableSize &&
        was.network.width == this->NetworkConfig.network.width &&
        was.network.hiddenLayers == this->NetworkConfig.network.hiddenLayers &&
        was.encoding.levels == this->NetworkConfig.encoding.levels;
      if (warm)
        model.params() = previous.params();
    }
    catch (const nv::Error&)
    {
      warm = false; // a seed that does not read is no seed
    }
  }
  this->WarmSeed.reset();
  if (!warm)
    model.initialize(this->Train.seed);
  this->WarmStart = warm;
  this->Session->setModel(model);
  this->InitialInstalled = true;
}

void Job::SetFinal(std::shared_ptr<const NetworkRecord> record)
{
  this->InitialInstalled = true; // the session holds this network already
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->FinalRecord = std::move(record);
  this->Decoded = nullptr;
}

void Job::FinalizeWithoutTraining()
{
  RunStatus status;
  status.EndReason = "constant field";
  this->Finalize(status);
  std::lock_guard<std::mutex> lock(this->Mutex);
  auto record = std::make_shared<NetworkRecord>(*this->FinalRecord);
  record->Figures.State = "Finished";
  this->FinalRecord = record;
}

void Job::WriteLiveBytes(const RunStatus& status)
{
  NetworkBytes bytes;
  int64_t modelBytes = 0;
  try
  {
    nv::Model model = this->Session->currentModel();
    // 8-bit coding of a large network takes most of a second: live snapshots stay fp16 (their ratio too), and the
    // 8-bit network is coded once, when training ends (Finalize).
    model.quantize(this->Storage == nv::Precision::Quantized8 ? nv::Precision::Float16 : this->Storage);
    model.corrections = nv::ErrorCorrections(); // live snapshots are not bounded: the phase end corrects
    model.stats.steps = status.Steps;
    model.stats.seconds = status.Seconds;
    model.stats.device = nv::deviceName(this->Session->device());
    bytes = ShareBytes(nv::serialize(model));
    modelBytes = model.parameterBytes();
  }
  catch (const std::exception&)
  {
    bytes.reset(); // out of memory for a copy: the previous snapshot stays (the final network is written anyway)
  }
  std::lock_guard<std::mutex> lock(this->Mutex);
  if (bytes)
  {
    this->LiveBytes = std::move(bytes);
    ++this->LiveBytesSerial;
    this->LiveModelBytes = modelBytes;
  }
  this->LiveBytesTime = std::chrono::steady_clock::now();
  this->LiveWriting = false;
}

bool Job::LiveBytesPending() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return this->LiveBytesSerial != this->LiveBytesSerialEmitted;
}

bool Job::WaitForFirstLiveBytes(double seconds)
{
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;)
  {
    const RunStatus status = this->Run->status();
    {
      std::lock_guard<std::mutex> lock(this->Mutex);
      if (this->LiveBytes)
        return true;
    }
    if (std::chrono::steady_clock::now() >= until || isSettled(status.State))
      return false;
    this->StartLiveWriterIfDue(status);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

void Job::StartLiveWriterIfDue(const RunStatus& status)
{
  // The bytes matter to consumers in other processes only (renderers here use the live session): serialized at
  // most once a second in a thread of their own (a large network takes a second and more), never in the caller's,
  // and only once the run has installed its initial network (RunState::Starting ends). Until the first ones exist
  // a snapshot has none (the filter shows the job as starting).
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    const auto now = std::chrono::steady_clock::now();
    if (this->LiveWriting || status.State == RunState::Starting ||
      (this->LiveBytes && now - this->LiveBytesTime <= std::chrono::seconds(1)))
      return;
    this->LiveWriting = true;
  }
  if (this->LiveWriter.joinable())
    this->LiveWriter.join(); // ended: LiveWriting was off
  try
  {
    this->LiveWriter = std::thread([this, status]() { this->WriteLiveBytes(status); });
  }
  catch (const std::system_error&)
  {
    this->WriteLiveBytes(status); // the system gives no thread: written in the caller's
  }
}

NetworkRecord Job::Snapshot()
{
  NetworkRecord r;
  r.Key = this->Key;
  r.Time = this->Time;
  const RunStatus status = this->Run->status();
  this->StartLiveWriterIfDue(status);
  Metrics& m = r.Figures;
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    r.Bytes = this->LiveBytes;
    this->LiveBytesSerialEmitted = this->LiveBytesSerial;
    m.ModelBytes = this->LiveModelBytes;
  }
  m.State = runStateName(status.State);
  m.Steps = status.Steps;
  m.Seconds = status.Seconds;
  m.Psnr = status.Psnr; // the probe's estimate (NaN before the first)
  m.PsnrFinal = false;
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    if (this->PausedFiguresStep >= 0 && this->PausedFiguresStep == status.Steps)
    {
      m.Psnr = this->PausedFigures.psnr; // measured over the whole file at this very step (MeasurePaused)
      m.MaxError = this->PausedFigures.maxAbsError;
      m.MaxErrorOfRange = this->PausedFigures.maxErrorOfRange;
      m.PsnrFinal = true;
    }
  }
  m.Ratio = static_cast<double>(this->Source.rawBytes) / static_cast<double>(std::max<int64_t>(m.ModelBytes, 1));
  m.Invalid = this->Field.Stats.invalid;
  m.DeviceMemoryBytes = status.DeviceMemoryBytes;
  m.Device = nv::deviceName(this->Session->device());
  m.CudaDevice = this->Session->cudaDevice();
  m.WarmStart = this->WarmStart;
  r.Log = this->Run->log();
  return r;
}

} // namespace vtkNeuralCompressInternals
