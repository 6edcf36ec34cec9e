// vtkNeuralCompress under MPI with an image input: one network per rank on its own piece, the global figures
// (vtkNeuralCompressPartition.h, vtkNeuralCompressGlobalFigures.h).
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressState.h"

#include "Core/Volume.h"

#include "vtkDataObject.h"
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

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

//------------------------------------------------------------------------------
nvi::PieceSums vtkNeuralCompress::MeasureCurrentPiece()
{
  vtkInternals& in = *this->Internals;
  nvi::Job* job = in.Current.get();
  std::shared_ptr<const nvi::NetworkRecord> final = job ? job->Final() : nullptr;
  if (!final || !job->Session || !job->Data || !job->Data->Field.View.data)
    return nvi::PieceSums();
  if (in.MeasuredRecord == final.get())
    return in.MeasuredSums;
  const nv::VolumeView& view = job->Data->Field.View;
  const double bytesPerSample =
    view.count() > 0 ? static_cast<double>(job->Data->Field.RawBytes) / static_cast<double>(view.count()) : 0.0;
  in.MeasuredSums = nvi::MeasurePiece(*job->Session, view, job->Field.InputExtent, in.Piece.Owned(),
    in.Piece.Whole(), job->Field.Cells, bytesPerSample, static_cast<double>(final->Figures.ModelBytes));
  in.MeasuredRecord = final.get();
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
  bool executed = false;
  nvi::PieceSums sums;
  // Every rank (a collective the first time, which also chooses this rank's GPU: vtkNeuralCudaDevice.h).
  const int ranksHere = nvi::RanksOnThisHost().Count;
  const bool hasPiece = in.Piece.Select(local, whole);
  if (hasPiece)
  {
    // The training image in an input information vector of its own (GetInputArrayToProcess reads the array there).
    vtkNew<vtkInformationVector> vector;
    vector->SetNumberOfInformationObjects(1);
    vector->GetInformationObject(0)->Copy(inInfo);
    vector->GetInformationObject(0)->Set(vtkDataObject::DATA_OBJECT(), in.Piece.Training());
    vtkInformationVector* vectors[1] = { vector };
    // Every rank trains to the end within this execution: the figures are reduced across ranks at its end, and
    // executions of one rank alone (a background run's refresh) could not take part in that.
    const bool background = this->TrainInBackground;
    this->TrainInBackground = false;
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
    this->TrainInBackground = background;
    this->Threads = threads;
    if (executed)
    {
      in.Piece.CropOutput(output);
      sums = this->MeasureCurrentPiece();
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
  sums.Failed = hasPiece && !executed ? 1.0 : 0.0;
  // Every rank, every execution: the whole field's figures, and the other ranks' networks to rank 0 for a saved state.
  const nvi::GlobalFigures global = nvi::ReduceFigures(sums);
  this->GatherPeerNetworks();
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
