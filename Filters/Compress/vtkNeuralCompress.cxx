#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressDecode.h"
#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressState.h"
#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressSparse.h"
#include "vtkNeuralNetworkArray.h"

#include "Core/Error.h"
#include "Core/Serialization.h"
#include "Core/ResourceEstimate.h"

#include "vtkAlgorithmOutput.h"
#include "vtkCellData.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"
#include "vtkTable.h"
#include "vtkTypeInt64Array.h"
#include "vtkPointSet.h"
#include "vtkUnstructuredGrid.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <sstream>


vtkStandardNewMacro(vtkNeuralCompress);

//------------------------------------------------------------------------------
vtkNeuralCompress::vtkNeuralCompress()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(3);
  this->SetInputArrayToProcess(0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS,
    vtkDataSetAttributes::SCALARS);
  this->RegisterForLiveUpdates();
}


vtkNeuralCompress::~vtkNeuralCompress()
{
  this->UnregisterForLiveUpdates();
  this->Internals->Preparing.reset(); // its thread uses this filter
  this->Internals->Current.reset();
}

//------------------------------------------------------------------------------
int vtkNeuralCompress::FillInputPortInformation(int, vtkInformation* info)
{
  // Any dataset or composite dataset (the whole composite arrives here: one network over the
  // union of its blocks).
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataSet");
  info->Append(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkCompositeDataSet");
  return 1;
}

int vtkNeuralCompress::FillOutputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkImageData" : "vtkTable");
  return 1;
}

int vtkNeuralCompress::RequestDataObject(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkDataObjectAlgorithm::SetOutputDataObject(
    VTK_IMAGE_DATA, outputVector->GetInformationObject(0), /*exact=*/true);
  vtkDataObjectAlgorithm::SetOutputDataObject(
    VTK_TABLE, outputVector->GetInformationObject(1), /*exact=*/true);
  vtkDataObjectAlgorithm::SetOutputDataObject(
    VTK_TABLE, outputVector->GetInformationObject(2), /*exact=*/true);
  return 1;
}

//------------------------------------------------------------------------------
int vtkNeuralCompress::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // An abort left set from before does not cut this update short (cleared here, before its first progress event).
  this->SetAbortExecute(0);
  // Training needs the whole field.
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo && inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    int ext[6];
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext);
    inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext, 6);
  }
  vtkDataObject* input = inInfo ? inInfo->Get(vtkDataObject::DATA_OBJECT()) : nullptr;
  if (nvi::PerRankNetworks(input))
    nvi::ImagePiece::RequestPaddedPiece(inInfo); // MPI, image: this rank's piece and ghost layers, trained here
  else
    nvi::RequestLocalPiece(inInfo); // MPI: this rank's piece of it, gathered to rank 0 in RequestData
  return 1;
}

//------------------------------------------------------------------------------
int vtkNeuralCompress::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  // An abort request belongs to the execution it interrupts: one left from before was cleared by
  // RequestUpdateExtent, and one asked at this execution's first progress event (before RequestData) is kept.
  vtkDataObject* inputObject = vtkDataObject::GetData(inputVector[0], 0);
  vtkImageData* output = vtkImageData::GetData(outputVector, 0);
  vtkTable* log = vtkTable::GetData(outputVector, 1);
  vtkTable* metrics = vtkTable::GetData(outputVector, 2);
  if (!output || !log || !metrics)
  {
    vtkErrorMacro("Neural Compress: missing output objects.");
    return 0;
  }
  output->Initialize();
  nvi::InitializeLog(log);
  nvi::InitializeMetrics(metrics);
  double time = 0.0;
  if (inputObject && inputObject->GetInformation()->Has(vtkDataObject::DATA_TIME_STEP()))
  {
    time = inputObject->GetInformation()->Get(vtkDataObject::DATA_TIME_STEP());
  }

  if (nvi::PerRankNetworks(inputObject))
  {
    // MPI, image input: every rank trains its own piece's network (vtkNeuralCompressPartition.h).
    this->ExecutePiece(vtkImageData::SafeDownCast(inputObject), inputVector[0]->GetInformationObject(0), output, log,
      metrics, time);
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), time);
    return 1;
  }
  if (this->Internals->GridPieces && nvi::PerRankDataSetType(inputObject))
  {
    // MPI, any other dataset, a composite or a particle set: every rank trains its own piece's network
    // (vtkNeuralCompressDataSetPiece.h, vtkNeuralCompressParticlePiece.h).
    this->ExecuteGridPiece(inputObject, inputVector[0]->GetInformationObject(0), output,
      log, metrics, time);
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), time);
    return 1;
  }
  // MPI, other inputs: rank 0 trains on the whole input gathered from every rank; the others output an empty image.
  const nvi::DistributedRole role =
    this->Internals->Distributed.Gather(this, inputObject, inputVector[0]->GetInformationObject(0));
  if (role == nvi::DistributedRole::Satellite)
  {
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), time);
    return 1;
  }
  if (role == nvi::DistributedRole::Root)
  {
    inputObject = this->Internals->Distributed.Whole();
    inputVector = this->Internals->Distributed.WholeVector();
  }
  const nvi::RootOnlyScope rootOnly(role == nvi::DistributedRole::Root); // VTK's filters on rank 0 alone
  bool executed = false;
  try
  {
    // One process training in the background: the field is prepared in the background too. Under MPI the ranks
    // take part in the gathering, so rank 0 prepares it here.
    const bool background = this->TrainInBackground && role == nvi::DistributedRole::Serial;
    executed = role != nvi::DistributedRole::Failed &&
      this->Execute(inputObject, inputVector, output, log, metrics, time, background);
  }
  catch (...)
  {
    // Execute reports the engine's and the standard library's errors itself; nothing else may leave the filter.
    vtkErrorMacro("Neural Compress: unexpected failure. The output is empty.");
  }
  this->ReportEngineWarnings();
  if (!executed)
  {
    // A defined result: no arrays, no network. For an image input the output keeps the promised
    // (input) geometry, so the pipeline does not execute again (and repeat the error) on every
    // update.
    this->Internals->Retire();
    nvi::InitializeOutputs(output, log, metrics, outputVector->GetInformationObject(0));
  }
  output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), time);

  return 1;
}

//------------------------------------------------------------------------------
namespace
{
/// The execution that started a background job of a small network (at most kFirstBytesWaitParameters) waits at most
/// this long for its first bytes: installed and serialized within milliseconds, the network is in that execution's
/// output. A larger one takes longer (0.2 s at 2^16 entries, 3.4 s at 2^21 on 2 cores): shown as preparing at once.
constexpr double kFirstBytesWaitSeconds = 0.04;
constexpr int64_t kFirstBytesWaitParameters = int64_t(1) << 20;


/// Seconds the run needs for its remaining steps at the rate of its log, or within its time budget (whichever comes
/// first); NaN when unknown (no rate yet, or a settled run).
double SecondsLeft(const nvi::NetworkRecord& record, const nv::RunStatus& status, double timeBudget)
{
  double left = std::numeric_limits<double>::quiet_NaN();
  if (nvi::isSettled(status.State) || status.State == nvi::RunState::Finishing)
    return left;
  if (record.Log.size() >= 2)
  {
    const nvi::LogRow& first = record.Log.front();
    const nvi::LogRow& last = record.Log.back();
    const double seconds = last.ElapsedSeconds - first.ElapsedSeconds;
    if (last.Step > first.Step && seconds > 0.0 && status.TargetSteps >= status.Steps)
      left = static_cast<double>(status.TargetSteps - status.Steps) * seconds / static_cast<double>(last.Step - first.Step);
  }
  if (timeBudget > 0.0 && status.Seconds < timeBudget)
    left = std::isnan(left) ? timeBudget - status.Seconds : std::min(left, timeBudget - status.Seconds);
  return left;
}

/// The panel's status line (Training Status): state, steps, PSNR, time; e.g. "Training: 1234/2000 steps, PSNR 41.2 dB
/// (estimate), 12.3 s, about 8 s left" or "Cached: 2000 steps (trained before in 52.1 s), PSNR 47.6 dB".
/// `status`: the run's (null when the network had no run: constant, cached, restored).
std::string StatusLine(const nvi::FieldInfo& field, const nvi::NetworkRecord& record, const nv::RunStatus* status,
  double timeBudget, bool fromCache)
{
  const nvi::Metrics& m = record.Figures;
  std::ostringstream text;
  text.precision(3);
  text << std::fixed;
  text << (fromCache ? "Cached" : m.State) << ": " << m.Steps;
  if (status)
    text << "/" << status->TargetSteps;
  text << " steps";
  const std::string reason = status ? std::string() : nvi::EndReasonText(field, m);
  if (!reason.empty() && !fromCache && !m.Restored)
    text << " (" << reason << ")";
  text.precision(2);
  if (std::isnan(m.Psnr))
    text << ", PSNR not estimated yet";
  else
    text << ", PSNR " << m.Psnr << " dB" << (m.PsnrFinal ? "" : " (estimate)");
  text.precision(1);
  if (fromCache)
    text << " (trained before in " << m.Seconds << " s)";
  else if (!m.Restored)
    text << ", " << m.Seconds << " s";
  const double left = status ? SecondsLeft(record, *status, timeBudget) : std::numeric_limits<double>::quiet_NaN();
  if (std::isfinite(left))
    text << ", about " << std::max(left, 0.0) << " s left";
  text.precision(2);
  if (m.Ratio > 0.0)
    text << ", ratio " << m.Ratio << ":1" << (m.Ratio < 1.0 ? " (model larger than the field: see the message)" : "");
  return text.str();
}

} // namespace

//------------------------------------------------------------------------------
bool vtkNeuralCompress::EmitOutputs(vtkImageData* output, vtkTable* log, vtkTable* metrics)
{
  vtkInternals& in = *this->Internals;
  nvi::Job& job = *in.Current;
  {
    std::lock_guard<std::mutex> lock(job.Mutex);
    job.OutputMode = this->OutputMode;
  }
  // OutputResolution is not part of the training: a change decodes the same network on the new grid.
  // The same cap as the announced extent (RequestInformation): at most what the network resolves.
  const nvi::OutputGeometry geometry =
    nvi::OutputGeometryOf(job.Field, this->OutputResolution, this->FinestResolution, this->BaseResolution);
  if (job.SetOutputGeometry(geometry))
    this->ReportOutputCap(geometry);
  nvi::RunStatus status;
  if (job.Run && !this->ReportRunStatus(job, status))
  {
    return false;
  }
  bool live = job.Run && !nvi::isSettled(status.State);
  if (live && job.Run->inBackground() && !job.FirstBytesAwaited &&
    nv::parameterCount(job.Layout()) <= kFirstBytesWaitParameters)
  {
    job.FirstBytesAwaited = true; // once per job: a large network's refreshes do not wait again
    job.WaitForFirstLiveBytes(kFirstBytesWaitSeconds);
    status = job.Run->status(); // a small network: shown by the execution that started its job
    live = !nvi::isSettled(status.State);
  }
  nvi::NetworkRecord record;
  vtkSmartPointer<vtkDataArray> decoded;
  if (!this->CurrentNetwork(job, live, record, decoded))
  {
    return false;
  }
  in.DecodeRequested = false;
  in.MeasureRequested = false; // a settled run's figures are exact already
  if (live && !nvi::HasBytes(record.Bytes))
  {
    // The run installs the job's first network in its thread, then its first snapshot is written: the geometry the
    // network will have, no network yet (Neural Volume draws nothing, without an error).
    const nv::ModelConfig config = job.Layout(); // the prologue may be searching the size (SizeForPSNR)
    nvi::InitializePreparingOutputs(output, log, metrics, this->GetOutputInformation(0), job.Source.bounds);
    std::ostringstream text;
    bool searching = status.State == nvi::RunState::Starting && job.SearchMaxLog2 > 0;
    if (searching)
    {
      std::lock_guard<std::mutex> lock(job.Mutex); // the prologue writes the note when the search ends
      searching = job.SizeNote.empty();
    }
    if (searching)
      text << "Preparing: training candidate sizes for PSNR " << job.TrainingSettings.SizeForPsnr << " dB (2^"
           << config.encoding.log2TableSize << " to 2^" << job.SearchMaxLog2 << " tables)";
    else
      text << "Preparing: " << (status.State == nvi::RunState::Starting ? "initialising" : "writing")
           << " the network (2^" << config.encoding.log2TableSize << " table, " << config.encoding.levels << " levels)";
    in.StatusText = text.str();
    return true;
  }
  if (!live && !in.SummaryPrinted)
  {
    // Complete for the first time in this job: a network with no run that the cache had for this time step and
    // input is one trained before (not a constant field seen for the first time, not one restored from a state).
    in.FromCache = !job.Run && !record.Figures.Restored && in.Cache.Find(job.Time, job.Key) != nullptr;
  }
  else if (live)
  {
    in.FromCache = false;
  }
  this->FillOutputs(job, record, decoded, live, output, log, metrics);
  output->GetFieldData()->RemoveArray("NeuralFromCache");
  vtkNew<vtkIntArray> fromCache;
  fromCache->SetName("NeuralFromCache");
  fromCache->InsertNextValue(in.FromCache ? 1 : 0);
  output->GetFieldData()->AddArray(fromCache);
  const double budget = this->Deterministic ? 0.0 : this->TimeBudget;
  in.StatusText = StatusLine(job.Field, record, job.Run ? &status : nullptr, budget, in.FromCache);
  if (!live && !in.SummaryPrinted)
  {
    // A network complete for the first time (re-executions of the same one emit it without this).
    in.Cache.Put(record);
    in.Cache.Trim(static_cast<int64_t>(this->NetworkCacheMiB) << 20, job.Time);
    in.SummaryPrinted = true;
    this->ReportFinalNetwork(job, record);
  }
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ReportRunStatus(nvi::Job& job, nv::RunStatus& status)
{
  vtkInternals& in = *this->Internals;
  status = job.Run->status();
  job.EmittedSerial = status.Serial;
  // A recovered divergence is a warning; keeping the best network is the normal course: text, as the summary.
  for (; in.WarningsPrinted < status.Warnings.size(); ++in.WarningsPrinted)
  {
    vtkWarningMacro("Neural Compress: " << status.Warnings[in.WarningsPrinted] << ".");
  }
  for (; in.NotesPrinted < status.Notes.size(); ++in.NotesPrinted)
  {
    vtkOutputWindowDisplayText(("Neural Compress: " + status.Notes[in.NotesPrinted] + ".\n").c_str());
  }
  if (status.State == nvi::RunState::Failed)
  {
    vtkErrorMacro("Neural Compress: training failed: " << status.Error);
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::CurrentNetwork(
  nvi::Job& job, bool live, nvi::NetworkRecord& record, vtkSmartPointer<vtkDataArray>& decoded)
{
  if (live)
  {
    if (this->Internals->MeasureRequested)
    {
      this->Internals->MeasureRequested = false;
      this->MeasureRequestedNow(job); // the snapshot below carries its figures
    }
    record = job.Snapshot();
    if (this->Internals->DecodeRequested)
    {
      decoded = this->DecodeNetwork(job);
    }
    return true;
  }
  std::shared_ptr<const nvi::NetworkRecord> final = job.Final();
  if (!final)
  {
    vtkErrorMacro("Neural Compress: the training ended without a network.");
    return false;
  }
  record = *final;
  decoded = job.FinalDecoded(this->OutputMode);
  std::string decodeError;
  {
    std::lock_guard<std::mutex> lock(job.Mutex);
    std::swap(decodeError, job.DecodeError);
  }
  if (!decodeError.empty())
  {
    vtkErrorMacro("Neural Compress: " << decodeError << " The output holds the network only.");
  }
  else if (!decoded)
  {
    decoded = this->DecodeNetwork(job);
    if (decoded)
    {
      job.KeepDecoded(decoded, this->OutputMode);
    }
  }
  return true;
}

//------------------------------------------------------------------------------
vtkSmartPointer<vtkDataArray> vtkNeuralCompress::DecodeNetwork(nvi::Job& job)
{
  // A decode in this thread: parallel, with progress and abort; a field it cannot make leaves the network alone.
  nvi::DecodeControl control;
  control.Abort = [this]() { return this->GetAbortExecute() != 0; };
  control.Progress = [this](double f) { this->UpdateProgress(f); };
  try
  {
    return nvi::DecodeOutput(*job.Session, job.Field, this->OutputMode, control);
  }
  catch (const nv::Error& e)
  {
    vtkErrorMacro("Neural Compress: " << e.what() << " The output holds the network only.");
  }
  return nullptr;
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::FillOutputs(nvi::Job& job, const nvi::NetworkRecord& record, vtkDataArray* decoded, bool live,
  vtkImageData* output, vtkTable* log, vtkTable* metrics)
{
  nvi::FillImage(output, job.Field, record, decoded, job.Session, live);
  nvi::FillLog(log, record);
  // One metrics row per time step: the cached networks of the other time steps, then this one.
  std::vector<const nvi::NetworkRecord*> rows;
  for (const nvi::NetworkRecord* r : this->Internals->Cache.All())
  {
    if (r->Time != job.Time)
      rows.push_back(r);
  }
  rows.push_back(&record);
  nvi::FillMetrics(metrics, rows);
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::ReportFinalNetwork(nvi::Job& job, const nvi::NetworkRecord& record)
{
  if (this->OutputMode == OUTPUT_FLOAT32 && !nvi::Float32Holds(job.Field.Stats.min, job.Field.Stats.max))
  {
    std::ostringstream range;
    range << std::setprecision(12) << job.Field.Stats.min << " to " << job.Field.Stats.max << ", a range of "
          << job.Field.Stats.max - job.Field.Stats.min;
    vtkWarningMacro("Neural Compress: float32 cannot hold the values of '"
      << job.Field.Name << "' (" << range.str() << ") to the network's accuracy: the decoded output is float64.");
  }
  if (record.Figures.State == "Aborted")
  {
    vtkWarningMacro("Neural Compress: training aborted (AbortExecute) at step "
      << record.Figures.Steps << " of " << this->TrainingSteps << ": the output holds the network of that step.");
  }
  if (nvi::UntrainedByRequest(job.Field, record.Figures))
  {
    vtkWarningMacro("Neural Compress: Training Steps is 0: no training was asked for, so the network is "
      << (record.Figures.WarmStart ? "the warm start's" : "its random initialisation") << " (PSNR "
      << record.Figures.Psnr << " dB). Set Training Steps above 0 to train it.");
  }
  if (nvi::MaxErrorOverflows(record.Figures))
  {
    vtkWarningMacro("Neural Compress: the max error, " << nvi::MaxErrorText(job.Field, record.Figures)
                                                        << ", is too large for a double: NeuralMaxError is inf and "
                                                           "NeuralMaxErrorOfRange holds it; every decoded value is finite.");
  }
  else if (std::isinf(record.Figures.MaxError))
  {
    vtkErrorMacro("Neural Compress: the network's output is NaN or Inf at some of the field's samples (training "
                  "diverged): no PSNR is reported. Lower LearningRate or check the input's range.");
  }
  if (!record.Figures.ErrorBoundNote.empty())
  {
    vtkWarningMacro("Neural Compress: Max Error " << this->MaxError << ": " << record.Figures.ErrorBoundNote << ".");
  }
  const nvi::Settings& settings = job.TrainingSettings;
  if (nvi::SizedForPsnr(settings) && !(record.Figures.Psnr >= settings.SizeForPsnr))
  {
    vtkWarningMacro("Neural Compress: Size For PSNR " << settings.SizeForPsnr << " dB not reached: the network has "
      << record.Figures.Psnr << " dB with a 2^" << job.NetworkConfig.encoding.log2TableSize << " table in "
      << record.Figures.Steps << " steps. More Training Steps (or a longer Time Budget), a larger Finest Resolution or "
      << "more Levels may reach it.");
  }
  else if (!nvi::SizedForPsnr(settings) && this->Log2TableSize <= 0 && this->TargetCompressionRatio > 0.0 &&
    record.Figures.Ratio < this->TargetCompressionRatio)
  {
    const std::string advice = nvi::SmallerModelAdvice(job);
    vtkWarningMacro("Neural Compress: the target compression ratio "
      << this->TargetCompressionRatio << ":1 is out of reach for this field and network "
      << "(the smallest hash table gives " << record.Figures.Ratio << ":1)"
      << (advice.empty() ? std::string(".") : "; try " + advice + "."));
  }
  vtkOutputWindowDisplayText(
    nvi::Summary(job.Field, job, record, this->TargetCompressionRatio, this->Internals->FromCache).c_str());
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "VectorMode: " << this->VectorMode << "\n"
     << indent << "VectorComponent: " << this->VectorComponent << "\n"
     << indent << "TrainingSteps: " << this->TrainingSteps << "\n"
     << indent << "TimeBudget: " << this->TimeBudget << "\n"
     << indent << "BatchSize: " << this->BatchSize << "\n"
     << indent << "LearningRate: " << this->LearningRate << "\n"
     << indent << "Seed: " << this->Seed << "\n"
     << indent << "Loss: " << this->Loss << "\n"
     << indent << "LearningRateSchedule: " << this->LearningRateSchedule << "\n"
     << indent << "TargetCompressionRatio: " << this->TargetCompressionRatio << "\n"
     << indent << "SizeForPSNR: " << this->SizeForPSNR << "\n"
     << indent << "Levels: " << this->Levels << "\n"
     << indent << "FeaturesPerLevel: " << this->FeaturesPerLevel << "\n"
     << indent << "Log2TableSize: " << this->Log2TableSize << "\n"
     << indent << "BaseResolution: " << this->BaseResolution << "\n"
     << indent << "FinestResolution: " << this->FinestResolution << "\n"
     << indent << "NetworkWidth: " << this->NetworkWidth << "\n"
     << indent << "HiddenLayers: " << this->HiddenLayers << "\n"
     << indent << "StoragePrecision: " << this->StoragePrecision << "\n"
     << indent << "Device: " << this->Device << "\n"
     << indent << "Threads: " << this->Threads << "\n"
     << indent << "TrainingStrategy: " << this->TrainingStrategy << "\n"
     << indent << "OutputResolution: " << this->OutputResolution[0] << " "
     << this->OutputResolution[1] << " " << this->OutputResolution[2] << "\n"
     << indent << "PSNRInterval: " << this->PSNRInterval << "\n"
     << indent << "TargetPSNR: " << this->TargetPSNR << "\n"
     << indent << "MaxError: " << this->MaxError << "\n"
     << indent << "OutputMode: " << this->OutputMode << "\n"
     << indent << "TrainInBackground: " << this->TrainInBackground << "\n"
     << indent << "Deterministic: " << this->Deterministic << "\n"
     << indent << "WarmStart: " << this->WarmStart << "\n"
     << indent << "NetworkCacheMiB: " << this->NetworkCacheMiB << "\n"
     << indent << "ContinueSteps: " << this->ContinueSteps << "\n";
}
