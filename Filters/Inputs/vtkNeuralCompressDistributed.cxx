#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressPieces.h"

#include "vtkNeuralCompress.h"
#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressResample.h"

#include "vtkAlgorithm.h"
#include "vtkAlgorithmOutput.h"
#include "vtkAppendDataSets.h"
#include "vtkCellData.h"
#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSet.h"
#include "vtkDataSetAttributes.h"
#include "vtkDemandDrivenPipeline.h"
#include "vtkDoubleArray.h"
#include "vtkDummyController.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationDoubleKey.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMatrix3x3.h"
#include "vtkMultiBlockDataSet.h"
#include "vtkMultiProcessController.h"
#include "vtkMultiProcessStream.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUniformGrid.h"
#include "vtkUniformGridAMR.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <cstdint>
#include <sstream>
#include <vector>

namespace vtkNeuralCompressInternals
{

//------------------------------------------------------------------------------
vtkMultiProcessController* DistributedController()
{
  vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
  return c && c->GetNumberOfProcesses() > 1 ? c : nullptr;
}

void RequestLocalPiece(vtkInformation* inInfo)
{
  vtkMultiProcessController* c = DistributedController();
  if (!c || !inInfo)
    return;
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), c->GetLocalProcessId());
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), c->GetNumberOfProcesses());
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
  // A composite input has no extent of its own: the output's (the lattice's) copied to it by the executive would
  // reach the structured blocks upstream as a request outside theirs.
  if (!inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    inInfo->Remove(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT());
}

void UpdateLocalPiece(vtkAlgorithm* self, vtkInformation* inInfo)
{
  vtkAlgorithm* producer = self->GetInputAlgorithm(0, 0);
  vtkAlgorithmOutput* connection = self->GetInputConnection(0, 0);
  if (producer && connection)
  {
    vtkNew<vtkInformation> request;
    RequestLocalPiece(request);
    if (inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
      request->CopyEntry(inInfo, vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    if (request->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    {
      int whole[6];
      request->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
      request->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), whole, 6);
      request->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    }
    vtkNew<vtkInformationVector> requests;
    requests->SetNumberOfInformationObjects(connection->GetIndex() + 1);
    requests->SetInformationObject(connection->GetIndex(), request);
    producer->Update(connection->GetIndex(), requests);
  }
}

RootOnlyScope::RootOnlyScope(bool active)
{
  if (!active)
    return;
  this->Saved = vtkMultiProcessController::GetGlobalController();
  this->Single = vtkSmartPointer<vtkDummyController>::New();
  vtkMultiProcessController::SetGlobalController(this->Single);
}

RootOnlyScope::~RootOnlyScope()
{
  if (this->Single)
    vtkMultiProcessController::SetGlobalController(this->Saved);
}

//------------------------------------------------------------------------------
DistributedInput::DistributedInput()
  : WholeInfo(vtkSmartPointer<vtkInformationVector>::New())
{
  this->WholeInfo->SetNumberOfInformationObjects(1);
  this->WholeVectors[0] = this->WholeInfo;
}

DistributedInput::~DistributedInput() = default;

DistributedInput::Signature DistributedInput::InputSignature(vtkAlgorithm* self, vtkDataObject* local)
{
  Signature s;
  s.Producer = self->GetInputAlgorithm(0, 0);
  vtkAlgorithmOutput* connection = self->GetInputConnection(0, 0);
  s.Port = connection ? connection->GetIndex() : -1;
  if (auto* executive = s.Producer ? vtkDemandDrivenPipeline::SafeDownCast(s.Producer->GetExecutive()) : nullptr)
    s.PipelineMTime = executive->GetPipelineMTime();
  s.HasTime = local && local->GetInformation()->Has(vtkDataObject::DATA_TIME_STEP());
  s.Time = s.HasTime ? local->GetInformation()->Get(vtkDataObject::DATA_TIME_STEP()) : 0.0;
  return s;
}

/// Rank 0: the whole input from the gathered pieces (images stitched, datasets and composites assembled), with the
/// local piece's time step; null with `problem` set on failure. Assembly warnings go to `self`'s output window.
static vtkSmartPointer<vtkDataObject> WholeInputOnRoot(vtkAlgorithm* self, vtkDataObject* local, vtkInformation* inInfo,
  const Selection& sel, const std::vector<vtkSmartPointer<vtkDataObject>>& pieces, bool gathered, int ranks,
  std::string& problem)
{
  vtkSmartPointer<vtkDataObject> whole;
  std::vector<std::string> warnings;
  if (!gathered || pieces.size() != size_t(ranks))
  {
    problem = "gathering the input's pieces from the " + std::to_string(ranks) + " ranks failed";
  }
  else if (vtkImageData::SafeDownCast(local))
  {
    int extent[6];
    const int* wholeExtent = nullptr;
    if (inInfo && inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    {
      inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
      wholeExtent = ValidExtent(extent) ? extent : nullptr;
    }
    whole = StitchImages(pieces, wholeExtent, problem);
  }
  else
  {
    whole = Assemble(pieces, sel, warnings, problem);
  }
  for (const std::string& w : warnings)
  {
    vtkWarningWithObjectMacro(self, "Neural Compress: " << w << ".");
  }
  if (whole && local)
  {
    whole->GetInformation()->CopyEntry(local->GetInformation(), vtkDataObject::DATA_TIME_STEP());
  }
  return whole;
}

void DistributedInput::Sync(
  vtkAlgorithm* self, vtkDataObject* local, vtkInformation* inInfo, const std::string& name, int association)
{
  vtkMultiProcessController* c = DistributedController();
  const Selection sel = Selected(self);
  const bool root = c->GetLocalProcessId() == kRoot;

  // Every rank: its piece to rank 0 (a collective every rank reaches: nothing before it can return early).
  vtkSmartPointer<vtkDataObject> piece = local ? MakePiece(local, sel) : nullptr;
  std::vector<vtkSmartPointer<vtkDataObject>> pieces;
  const int gathered = c->Gather(piece, pieces, kRoot);

  this->WholeObject = nullptr;
  this->Problem.clear();
  int ok = 0;
  int autoDims[3] = { 0, 0, 0 };
  std::string statsProblem = "the input was not gathered";
  if (root)
  {
    const RootOnlyScope alone(true);
    this->WholeObject =
      WholeInputOnRoot(self, local, inInfo, sel, pieces, gathered != 0, c->GetNumberOfProcesses(), this->Problem);
    // A resampled input: the automatic sampling dimensions of the whole input (as serial would compute them).
    if (this->WholeObject && !vtkImageData::SafeDownCast(local) && !name.empty())
    {
      const int automatic[3] = { 0, 0, 0 };
      statsProblem.clear();
      ok = ResolveSamplingDimensions(this->WholeObject, name, association, automatic, autoDims, statsProblem) ? 1 : 0;
    }
    else if (!this->WholeObject)
    {
      statsProblem = this->Problem;
    }
  }
  this->WholeInfo->GetInformationObject(0)->Set(vtkDataObject::DATA_OBJECT(), this->WholeObject);
  if (!this->WholeObject)
    this->WholeInfo->GetInformationObject(0)->Remove(vtkDataObject::DATA_OBJECT());

  // Every rank: the statistics of the whole input (the extent every rank announces).
  vtkMultiProcessStream stream;
  if (root)
    stream << ok << autoDims[0] << autoDims[1] << autoDims[2] << statsProblem;
  c->Broadcast(stream, kRoot);
  if (!root)
    stream >> ok >> autoDims[0] >> autoDims[1] >> autoDims[2] >> statsProblem;
  this->StatsValid = true;
  this->StatsOk = ok != 0;
  std::copy(autoDims, autoDims + 3, this->AutoDims);
  this->StatsProblem = statsProblem;

  this->Synced = true;
  this->Input = InputSignature(self, local);
  this->Name = name;
  this->Association = association;
}

DistributedRole DistributedInput::Gather(vtkAlgorithm* self, vtkDataObject* local, vtkInformation* inInfo)
{
  vtkMultiProcessController* c = DistributedController();
  if (!c)
    return DistributedRole::Serial;
  const Selection sel = Selected(self);
  const bool changed = !this->Synced || !(InputSignature(self, local) == this->Input) || sel.Name != this->Name ||
    sel.Association != this->Association;
  if (changed)
    this->Sync(self, local, inInfo, sel.Name, sel.Association);
  if (c->GetLocalProcessId() != kRoot)
    return DistributedRole::Satellite;
  if (!this->WholeObject)
  {
    vtkErrorWithObjectMacro(self, "Neural Compress: cannot assemble the whole input on rank 0: "
                              << this->Problem << ". The output is empty.");
    return DistributedRole::Failed;
  }
  return DistributedRole::Root;
}

void DistributedInput::Announce(vtkAlgorithm* self, vtkInformation* inInfo, vtkInformation* outInfo,
  const int requested[3], const int outputResolution[3], int announced[3])
{
  std::fill(announced, announced + 3, 0);
  vtkMultiProcessController* c = DistributedController();
  const Selection sel = Selected(self);
  if (!c || sel.Name.empty())
  {
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    return;
  }
  if (!this->StatsValid || sel.Name != this->Name || sel.Association != this->Association)
  {
    // Every rank (the first update, or a new array: the same on every rank): the input brought up to date as this
    // rank's piece, then gathered.
    UpdateLocalPiece(self, inInfo);
    this->Sync(self, inInfo->Get(vtkDataObject::DATA_OBJECT()), inInfo, sel.Name, sel.Association);
  }
  if (!this->StatsOk)
  {
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    return;
  }
  int dims[3];
  std::copy(requested, requested + 3, dims);
  if (dims[0] <= 0 || dims[1] <= 0 || dims[2] <= 0)
    std::copy(this->AutoDims, this->AutoDims + 3, dims);
  if (double(dims[0]) * dims[1] * dims[2] > 1024.0 * 1024.0 * 1024.0)
  {
    // Rank 0's Execute reports it (as in serial).
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    return;
  }
  const int ext[6] = { 0, dims[0] - 1, 0, dims[1] - 1, 0, dims[2] - 1 };
  const double origin[3] = { 0, 0, 0 }, spacing[3] = { 1, 1, 1 };
  // The same cap as rank 0's Execute applies (twice the finest level per axis).
  vtkNeuralCompress* filter = vtkNeuralCompress::SafeDownCast(self);
  const OutputGeometry g = ComputeGeometry(ext, origin, spacing, false, outputResolution,
    filter ? filter->GetFinestResolution() : -1, filter ? filter->GetBaseResolution() : 0);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), g.Extent, 6);
  std::copy(dims, dims + 3, announced);
}

} // namespace vtkNeuralCompressInternals
