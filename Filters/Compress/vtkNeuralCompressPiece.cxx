// vtkNeuralCompress under MPI with an image input or another dataset or composite: one network per rank on its
// own piece, the global figures (vtkNeuralCompressPartition.h, vtkNeuralCompressDataSetPiece.h,
// vtkNeuralCompressGlobalFigures.h), and the live updates of background training:
// ParaView's live-source poll asks rank 0 alone (GetNeedsUpdate), rank 0 asks the other ranks by an RMI, and every
// rank is Modified() when one rank's run has something new, so the update that follows executes on every rank.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressState.h"
#include "vtkNeuralOutOfCoreInput.h"

#include "Core/Volume.h"

#include "vtkAbstractArray.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSet.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkMultiProcessStream.h"
#include "vtkNew.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkTable.h"
#include "vtkVariant.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace
{
/// The filters of this process by their number (the same on every rank), for the live-update RMI.
struct LiveUpdateList
{
  std::mutex Mutex;
  std::map<uint64_t, vtkNeuralCompress*> Filters;
  uint64_t Next = 1;
  bool RmiAdded = false;
};

LiveUpdateList& LiveUpdates()
{
  static LiveUpdateList list;
  return list;
}

/// The ranks' training states ("Training", ...) of an output: a live output, one whose run still trains.
bool IsLiveState(const std::string& state)
{
  return state == "Starting" || state == "Training" || state == "Paused" || state == "Preparing" ||
    state == "Finishing";
}
} // namespace

//------------------------------------------------------------------------------
void vtkNeuralCompress::RegisterForLiveUpdates()
{
  LiveUpdateList& list = LiveUpdates();
  std::lock_guard<std::mutex> lock(list.Mutex);
  this->Internals->LiveUpdateId = list.Next++;
  list.Filters[this->Internals->LiveUpdateId] = this;
  vtkMultiProcessController* c = nvi::DistributedController();
  if (c && !list.RmiAdded)
  {
    c->AddRMICallback(&vtkNeuralCompress::LiveUpdateRmi, nullptr, nvi::kLiveUpdateRmiTag);
    list.RmiAdded = true;
  }
}

void vtkNeuralCompress::UnregisterForLiveUpdates()
{
  LiveUpdateList& list = LiveUpdates();
  std::lock_guard<std::mutex> lock(list.Mutex);
  list.Filters.erase(this->Internals->LiveUpdateId);
}

void vtkNeuralCompress::LiveUpdateRmi(void*, void* remoteArg, int remoteArgLength, int)
{
  vtkMultiProcessController* c = nvi::DistributedController();
  if (!c)
    return;
  uint64_t id = 0;
  if (remoteArg && remoteArgLength == static_cast<int>(sizeof(id)))
    std::memcpy(&id, remoteArg, sizeof(id));
  vtkNeuralCompress* filter = nullptr;
  {
    LiveUpdateList& list = LiveUpdates();
    std::lock_guard<std::mutex> lock(list.Mutex);
    auto found = list.Filters.find(id);
    filter = found != list.Filters.end() ? found->second : nullptr;
  }
  if (filter)
    filter->NeedsUpdateOnEveryRank(c, filter->LocalNeedsUpdate());
  else
  {
    int none = 0, any = 0; // no such filter here: this rank still takes part in the decision
    c->AllReduce(&none, &any, 1, vtkCommunicator::MAX_OP);
  }
}

bool vtkNeuralCompress::NeedsUpdateOnEveryRank(vtkMultiProcessController* c, bool local)
{
  int mine = local ? 1 : 0, any = 0;
  c->AllReduce(&mine, &any, 1, vtkCommunicator::MAX_OP);
  if (any)
    this->Modified();
  return any != 0;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::TrainingLive()
{
  nvi::Job* job = this->Internals->Current.get();
  return job && job->Run && !nvi::isSettled(job->Run->status().State);
}

nvi::PieceSums vtkNeuralCompress::EstimateCurrentPiece(vtkImageData* output)
{
  vtkInternals& in = *this->Internals;
  nvi::Job* job = in.Current.get();
  if (!job || !output)
    return nvi::PieceSums();
  vtkFieldData* fd = output->GetFieldData();
  auto value = [fd](const char* name) {
    vtkDataArray* a = vtkDataArray::SafeDownCast(fd->GetAbstractArray(name));
    return a && a->GetNumberOfTuples() > 0 ? a->GetTuple1(0) : std::nan("");
  };
  vtkDataArray* range = vtkDataArray::SafeDownCast(fd->GetAbstractArray("NeuralValueRange"));
  const double lo = range && range->GetNumberOfTuples() >= 2 ? range->GetTuple1(0) : job->Field.Stats.min;
  const double hi = range && range->GetNumberOfTuples() >= 2 ? range->GetTuple1(1) : job->Field.Stats.max;
  const nv::VolumeView& view = job->Data ? job->Data->Field.View : nv::VolumeView();
  const double bytesPerSample =
    view.count() > 0 ? static_cast<double>(job->Data->Field.RawBytes) / static_cast<double>(view.count()) : 0.0;
  const double modelBytes = value("NeuralModelBytes");
  return nvi::EstimatePiece(in.Piece.Owned(), in.Piece.Whole(), job->Field.Cells, value("NeuralPSNR"), lo, hi,
    bytesPerSample, std::isfinite(modelBytes) ? modelBytes : 0.0);
}

//------------------------------------------------------------------------------
nvi::PieceSums vtkNeuralCompress::MeasureCurrentPiece()
{
  vtkInternals& in = *this->Internals;
  nvi::Job* job = in.Current.get();
  std::shared_ptr<const nvi::NetworkRecord> final = job ? job->Final() : nullptr;
  if (!final || !job->Session || !job->Data || (!job->Data->Field.View.data && !job->Field.OutOfCore))
    return nvi::PieceSums();
  if (in.MeasuredRecord.lock() == final)
    return in.MeasuredSums;
  if (job->Field.OutOfCore)
  {
    // An out-of-core piece (vtkNeuralOutOfCoreInput.h): its own samples read from the file, never in memory.
    try
    {
      in.MeasuredSums = nvi::MeasureOutOfCorePiece(*job->Session, *job->Field.OutOfCore, job->Field,
        in.Piece.Owned(), in.Piece.Whole(), static_cast<double>(final->Figures.ModelBytes));
    }
    catch (const std::exception& e)
    {
      vtkErrorMacro("Neural Compress: measuring this rank's piece of the file failed: " << e.what());
      in.MeasuredSums = nvi::PieceSums();
      in.MeasuredSums.Failed = 1.0;
      return in.MeasuredSums; // measured again next time
    }
    in.MeasuredRecord = final;
    return in.MeasuredSums;
  }
  const nv::VolumeView& view = job->Data->Field.View;
  const double bytesPerSample =
    view.count() > 0 ? static_cast<double>(job->Data->Field.RawBytes) / static_cast<double>(view.count()) : 0.0;
  in.MeasuredSums = nvi::MeasurePiece(*job->Session, view, job->Field.InputExtent, in.Piece.Owned(),
    in.Piece.Whole(), job->Field.Cells, bytesPerSample, static_cast<double>(final->Figures.ModelBytes));
  in.MeasuredRecord = final;
  return in.MeasuredSums;
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::GatherPeerNetworks()
{
  vtkInternals& in = *this->Internals;
  vtkMultiProcessController* c = nvi::DistributedController();
  if (!c)
    return;
  std::vector<const nvi::NetworkRecord*> records;
  for (const nvi::NetworkRecord* r : in.Cache.All())
  {
    if (r->Figures.State != "Interrupted")
      records.push_back(r);
  }
  // Only when some rank's networks changed since the last gather (the same decision on every rank).
  uint64_t signature = records.size();
  for (const nvi::NetworkRecord* r : records)
    signature = signature * 1099511628211ull ^ r->Key ^ reinterpret_cast<uintptr_t>(r->Bytes.get());
  int changed = signature != in.GatheredSignature ? 1 : 0, anyChanged = changed;
  c->AllReduce(&changed, &anyChanged, 1, vtkCommunicator::MAX_OP);
  in.GatheredSignature = signature;
  if (!anyChanged)
    return;
  // ";key:base64;..." of this rank (EncodeNetworks' text without its "nvnet1" header).
  const std::string own = nvi::EncodeNetworks(records).substr(std::strlen("nvnet1"));
  vtkMultiProcessStream send;
  send << own;
  std::vector<vtkMultiProcessStream> all;
  c->Gather(send, all, 0);
  in.PeerNetworksText.clear();
  for (size_t r = 1; r < all.size(); ++r)
  {
    std::string peer;
    all[r] >> peer;
    in.PeerNetworksText += peer;
  }
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::ExecutePiece(
  vtkImageData* local, vtkInformation* inInfo, vtkImageData* output, vtkTable* log, vtkTable* metrics, double time)
{
  vtkInternals& in = *this->Internals;
  int whole[6];
  if (inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  else
    local->GetExtent(whole);
  // Every rank (a collective the first time, which also chooses this rank's GPU: vtkNeuralCudaDevice.h).
  const int ranksHere = nvi::RanksOnThisHost().Count;
  const bool hasPiece = in.Piece.Select(local, whole);
  this->TrainPiece(hasPiece, ranksHere, -1.0, inInfo, output, log, metrics, time);
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::ExecuteGridPiece(
  vtkDataObject* local, vtkInformation* inInfo, vtkImageData* output, vtkTable* log, vtkTable* metrics, double time)
{
  vtkInternals& in = *this->Internals;
  const int ranksHere = nvi::RanksOnThisHost().Count; // a collective the first time (see ExecutePiece)
  vtkInformation* ai = this->GetInputArrayInformation(0);
  const char* name = ai && ai->Has(vtkDataObject::FIELD_NAME()) ? ai->Get(vtkDataObject::FIELD_NAME()) : nullptr;
  const int association =
    ai && ai->Has(vtkDataObject::FIELD_ASSOCIATION()) ? ai->Get(vtkDataObject::FIELD_ASSOCIATION()) : -1;
  std::string problem;
  // Every rank takes part in the preparation's collectives, whatever its array selection says.
  const bool prepared = in.ParticlePieces
    ? in.Particles.Prepare(local, name ? name : "", association, this->SamplingDimensions, ParticleSettingsOf(this),
        problem)
    : in.GridPiece.Prepare(local, name ? name : "", association, this->SamplingDimensions, problem);
  if (!prepared)
  {
    if (!name || !*name)
      problem = "no input array; select a numeric point or cell array (SelectInputScalars)";
    vtkErrorMacro("Neural Compress: cannot resample this rank's piece of the "
      << (local ? local->GetClassName() : "empty") << " input: " << problem << ". The output is empty.");
  }
  const bool particles = in.ParticlePieces;
  const bool hasPiece = prepared && (particles ? in.Particles.HasPiece() : in.GridPiece.HasPiece());
  if (hasPiece && particles)
    in.Piece.Adopt(in.Particles.Training(), in.Particles.Owned(), in.Particles.Whole());
  else if (hasPiece)
    in.Piece.Adopt(in.GridPiece.Training(), in.GridPiece.Owned(), in.GridPiece.Whole());
  in.GridPieceActive = hasPiece;
  const double sourceBytes = particles ? in.Particles.SourceBytes() : in.GridPiece.SourceBytes();
  this->TrainPiece(hasPiece, ranksHere, hasPiece ? sourceBytes : -1.0, inInfo, output, log, metrics, time);
  in.GridPieceActive = false;
  if (output->GetNumberOfPoints() > 0)
  {
    // The source samples this rank's network was trained from: its own piece's (no gather).
    vtkNew<vtkDoubleArray> own;
    own->SetName("NeuralPieceSourceSamples");
    own->InsertNextValue(particles ? in.Particles.SourceSamples() : in.GridPiece.SourceSamples());
    output->GetFieldData()->AddArray(own);
    if (particles)
    {
      // The reconstruction this rank trained on, over its own region (vtkNeuralCompressParticlePiece.h).
      vtkNew<vtkDoubleArray> sums;
      sums->SetName("NeuralPieceTrainingSums");
      for (double v : in.Particles.OwnedSums())
        sums->InsertNextValue(v);
      output->GetFieldData()->AddArray(sums);
    }
  }
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::TrainPiece(bool hasPiece, int ranksHere, double sourceBytes, vtkInformation* inInfo,
  vtkImageData* output, vtkTable* log, vtkTable* metrics, double time)
{
  vtkInternals& in = *this->Internals;
  bool executed = false;
  nvi::PieceSums sums;
  if (hasPiece)
  {
    // The training image in an input information vector of its own (GetInputArrayToProcess reads the array there).
    vtkNew<vtkInformationVector> vector;
    vector->SetNumberOfInformationObjects(1);
    vector->GetInformationObject(0)->Copy(inInfo);
    vector->GetInformationObject(0)->Set(vtkDataObject::DATA_OBJECT(), in.Piece.Training());
    vtkInformationVector* vectors[1] = { vector };
    // The piece is prepared within the execution (every rank's executions take part in the reduction at their
    // end); with TrainInBackground its run then trains in the background and the live updates are collective
    // (GetNeedsUpdate).
    // Threads = 0 (automatic): the host's cores shared among the ranks on it.
    const int threads = this->Threads;
    if (threads == 0)
      this->Threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / ranksHere);
    try
    {
      executed = this->Execute(in.Piece.Training(), vectors, output, log, metrics, time, false);
    }
    catch (...)
    {
      vtkErrorMacro("Neural Compress: unexpected failure. The output is empty.");
    }
    this->Threads = threads;
    if (executed)
    {
      in.Piece.CropOutput(output);
      vtkAbstractArray* state = output->GetFieldData()->GetAbstractArray("NeuralTrainingState");
      const bool live = this->TrainingLive() || (state && IsLiveState(state->GetVariantValue(0).ToString()));
      sums = live ? this->EstimateCurrentPiece(output) : this->MeasureCurrentPiece();
      if (sourceBytes >= 0.0)
        sums.FieldBytes = sourceBytes; // a resampled grid: the ratio counts the rank's own source samples
    }
  }
  this->ReportEngineWarnings();
  if (!executed)
  {
    in.Retire();
    output->Initialize(); // this rank draws and counts nothing
    nvi::InitializeLog(log);
    nvi::InitializeMetrics(metrics);
  }
  sums.Failed = (hasPiece && !executed) || sums.Failed > 0.0 ? 1.0 : 0.0; // a failed measurement: reported
  // Every rank, every execution: the whole field's figures, and the other ranks' networks to rank 0 for a saved state.
  const nvi::GlobalFigures global = nvi::ReduceFigures(sums);
  this->GatherPeerNetworks();
  // Every rank, every execution: the coarse grid of the whole field for shadows and path tracing across pieces.
  std::string problem;
  in.Surroundings.Update(executed ? output : nullptr, problem);
  if (!problem.empty())
    vtkWarningMacro("Neural Compress: " << problem << "; shadows and path tracing stop at this rank's piece.");
  if (!executed)
    return;
  vtkMultiProcessController* c = nvi::DistributedController();
  const int ranks = c ? c->GetNumberOfProcesses() : 1;
  if (global.Failed > 0 || global.Samples < global.WholeSamples)
  {
    // One network per rank describes the field only together: a rank that failed (it reported why) or pieces
    // that leave samples out make every rank's output empty, as a failure in one process would.
    if (global.Failed > 0)
      vtkErrorMacro("Neural Compress: " << global.Failed << " of the " << ranks
                                        << " ranks could not train their piece (see their messages). The output "
                                           "is empty.");
    else
      vtkErrorMacro("Neural Compress: the ranks' pieces cover " << static_cast<int64_t>(global.Samples) << " of the "
                                                                << static_cast<int64_t>(global.WholeSamples)
                                                                << " samples of the whole extent. The output is empty.");
    output->Initialize();
    nvi::InitializeLog(log);
    nvi::InitializeMetrics(metrics);
    return;
  }
  nvi::WriteGlobalFigures(output, metrics, global);
}
