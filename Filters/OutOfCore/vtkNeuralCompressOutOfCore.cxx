// vtkNeuralCompress on an out-of-core reader's output (vtkNeuralOutOfCoreInput.h): the training field is the file,
// never loaded -- its header, one streamed pass for the value range, a random block buffer within MemoryBudget as the
// trainer's batch source and a probe on random rows of it; the figures at a phase end (and on MeasureNow while
// paused) come from a streamed pass over every voxel of the file.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressPreparation.h"
#include "vtkNeuralCompressPartition.h"
#include "vtkNeuralCompressState.h"
#include "vtkNeuralCudaDevice.h"
#include "vtkNeuralHdf5Layout.h"
#include "vtkNeuralOutOfCoreInput.h"

#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/ResourceEstimate.h"
#include "OutOfCore/FileMeasure.h"

#include "vtkDataObject.h"
#include "vtkType.h"

#include <cmath>
#include <limits>
#include <sstream>

namespace nvi = vtkNeuralCompressInternals;

namespace
{
int VtkTypeOf(nv::ScalarType type)
{
  switch (type)
  {
    case nv::ScalarType::Int8: return VTK_SIGNED_CHAR;
    case nv::ScalarType::UInt8: return VTK_UNSIGNED_CHAR;
    case nv::ScalarType::Int16: return VTK_SHORT;
    case nv::ScalarType::UInt16: return VTK_UNSIGNED_SHORT;
    case nv::ScalarType::Int32: return VTK_INT;
    case nv::ScalarType::UInt32: return VTK_UNSIGNED_INT;
    case nv::ScalarType::Int64: return VTK_LONG_LONG;
    case nv::ScalarType::UInt64: return VTK_UNSIGNED_LONG_LONG;
    case nv::ScalarType::Float32: return VTK_FLOAT;
    case nv::ScalarType::Float64: return VTK_DOUBLE;
  }
  return VTK_FLOAT;
}

/// The field's name, type and geometry (points of the file's grid) and the file itself.
void DescribeFile(const std::shared_ptr<const nvi::OutOfCoreFile>& file, const int outputResolution[3], int finest,
  int base, nvi::FieldInfo& field)
{
  const nv::VolumeFileLayout& layout = file->Layout;
  field.Name = layout.arrayName.empty() ? "Scalars" : layout.arrayName;
  field.Cells = false;
  field.VtkType = VtkTypeOf(layout.type);
  int ext[6]; // the file's samples, or the rank's piece of them (a sub-box: vtkNeuralOutOfCoreInput.h)
  for (int a = 0; a < 3; ++a)
  {
    ext[2 * a] = static_cast<int>(layout.boxOrigin[a]);
    ext[2 * a + 1] = static_cast<int>(layout.boxOrigin[a] + layout.dims[a] - 1);
  }
  std::copy(ext, ext + 6, field.InputExtent);
  std::copy(layout.origin, layout.origin + 3, field.InputOrigin);
  std::copy(layout.spacing, layout.spacing + 3, field.InputSpacing);
  field.Geometry = nvi::OutputGeometryOf(field, outputResolution, finest, base); // MPI: the field's piece frame
  field.OutOfCore = file;
}
} // namespace

//------------------------------------------------------------------------------
bool vtkNeuralCompress::PrepareOutOfCoreField(
  const nvi::InputRequest& request, const nvi::Settings& settings, nvi::PreparedField& prepared)
{
  nvi::Preparation* background = nvi::Preparation::OfThisThread();
  auto carryOn = [this, background]() {
    return background ? !background->Cancelled() : this->GetAbortExecute() == 0;
  };
  if (background)
    background->SetStage("reading the file's header");
  auto file = std::make_shared<nvi::OutOfCoreFile>();
  file->Layout = nvi::ReadOutOfCoreLayout(request.OutOfCorePath, request.OutOfCoreArray); // nv::Error: reported
  // Under MPI the rank's padded piece alone: every read below (value range, block buffer, probe, exact pass) stays in it.
  file->Layout = nvi::OutOfCorePiece(file->Layout, request.OutOfCoreExtent);
  file->Layout.readTally = std::make_shared<nv::FileReadTally>();
  file->Reader = std::make_shared<nv::VolumeFileReader>(file->Layout);
  file->BudgetBytes = nvi::OutOfCoreBudgetBytes(
    settings.MemoryBudgetMiB, file->Layout.bytes(), file->BudgetReason, nvi::KnownRanksOnThisHost());
  file->BufferReads = settings.BypassPageCache ? nv::PageCacheUse::Bypass : nv::PageCacheUse::Normal;
  // (Device CUDA without a usable GPU is reported when the job starts; here it only chooses the readers.)
  const bool gpuTrainer = settings.Device != DEVICE_CPU &&
    nv::resolveDevice(nv::Device::Auto, nullptr, vtkNeuralCudaDevice::Get()) == nv::Device::Cuda;
  file->ReaderThreads = nvi::OutOfCoreReaderThreads(gpuTrainer, file->BufferReads);
  file->GpuTrainer = gpuTrainer;
  nvi::CheckOutOfCoreStorage(*file); // chunks the budget cannot decode: nv::Error, reported
  nvi::FieldInfo& field = prepared.Field;
  std::copy(request.PieceOwned, request.PieceOwned + 6, field.PieceOwned);
  std::copy(request.PieceWhole, request.PieceWhole + 6, field.PieceWhole);
  DescribeFile(file, this->OutputResolution, this->FinestResolution, this->BaseResolution, field);
  this->ReportOutputCap(field.Geometry);
  // The value range normalises the targets: one streamed pass over the file before training (abortable).
  int lastPercent = -1;
  nvi::OutOfCorePhaseLog rangeLog("value-range pass", "every voxel of " + nv::formatBytes(file->Layout.bytes()) +
      (file->Layout.fileBytes() > file->Layout.bytes() ? " (this rank's piece)" : ""));
  const nv::FileValueRange range =
    nv::scanValueRange(*file->Reader, nvi::OutOfCoreSlabBytes(*file), [&](double fraction) {
      rangeLog.Progress(fraction);
      const int percent = static_cast<int>(fraction * 100.0);
      if (background && percent != lastPercent)
        background->SetStage("scanning the file's value range, " + std::to_string(percent) + "%");
      lastPercent = percent;
      return carryOn();
    });
  file->ValueRangeSeconds = rangeLog.Finish();
  if (range.finite == 0)
  {
    this->Report(nvi::QueuedMessage::Error, "Neural Compress: all " + std::to_string(range.nonFinite) +
        " samples of '" + request.OutOfCorePath + "' are NaN or Inf; nothing to train on.");
    return false;
  }
  field.Stats.min = range.min;
  field.Stats.max = range.max;
  field.Stats.valid = range.finite;
  field.Stats.invalid = range.nonFinite;
  if (background)
    background->SetStage("filling the block buffer");
  if (!carryOn())
    return false;
  prepared.Data =
    nvi::OutOfCoreTrainingData(file, field.Stats, static_cast<uint64_t>(settings.Seed), settings.BatchSize);
  field.Description = prepared.Data->Field.Description;
  prepared.TrainingSettings = settings;
  prepared.Key = nvi::OutOfCoreKey(*file, field, settings);
  return carryOn();
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::MeasureRequestedNow(nvi::Job& job)
{
  if (!job.Field.OutOfCore)
  {
    vtkWarningMacro("Neural Compress: Measure Now applies to out-of-core inputs (Neural Out-of-Core Reader); the "
                    "figures of other inputs are measured over every sample at the end of each phase.");
    return false;
  }
  if (!job.Run || job.Run->status().State != nvi::RunState::Paused)
  {
    vtkWarningMacro("Neural Compress: Measure Now measures a paused run: pause the training first (a finished "
                    "run's figures are exact already).");
    return false;
  }
  std::string problem;
  if (!job.MeasurePaused([this]() { return this->GetAbortExecute() != 0; },
        [this](double fraction) { this->UpdateProgress(fraction); }, problem))
  {
    vtkWarningMacro("Neural Compress: the measurement over the file did not end (" << problem
                                                                                   << "); the PSNR shown stays the estimate.");
    return false;
  }
  return true;
}

namespace vtkNeuralCompressInternals
{

//------------------------------------------------------------------------------
bool Job::MeasurePaused(
  const std::function<bool()>& abort, const std::function<void(double)>& progress, std::string& problem)
{
  const RunStatus status = this->Run->status();
  try
  {
    const nv::ErrorStats figures = MeasureOutOfCore(
      *this->Session, *this->Field.OutOfCore, this->Field.Stats.min, this->Field.Stats.max, abort, progress);
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->PausedFigures = figures;
    this->PausedFiguresStep = status.Steps;
    return true;
  }
  catch (const std::exception& e)
  {
    problem = e.what();
  }
  return false;
}

//------------------------------------------------------------------------------
Job::PhaseMeasurement Job::MeasureOutOfCoreFile(const FieldInfo& field, const RunStatus& status, bool abortedBefore)
{
  PhaseMeasurement measured;
  auto abort = [this, abortedBefore]() {
    return this->Retiring.load() || (!abortedBefore && this->DecodeAbort && this->DecodeAbort());
  };
  try
  {
    measured.Error = MeasureOutOfCore(
      *this->Session, *field.OutOfCore, field.Stats.min, field.Stats.max, abort, this->DecodeProgress);
  }
  catch (const std::exception&)
  {
    // Aborted (or the file became unreadable): the figures stay the last estimate, labelled as such.
    measured.Exact = false;
    measured.Error.psnr = status.Psnr;
    measured.Error.maxAbsError = measured.Error.maxErrorOfRange = std::numeric_limits<double>::quiet_NaN();
  }
  return measured;
}

} // namespace vtkNeuralCompressInternals
