// vtkNeuralCompress in the background (TrainInBackground, one process): a new input's field is prepared in a thread
// of its own (vtkNeuralCompressPreparation.h) while executions return at once with the previous network, then its
// job starts in the filter's thread.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressPreparation.h"
#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressState.h"

#include "Core/Error.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"

#include <algorithm>
#include <new>

namespace
{
/// How long an execution waits for a new preparation before it returns with the previous network (or none): the
/// GUI stays answering, and small inputs start training within the execution that asked.
constexpr double kPreparationWaitSeconds = 0.05;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ExecuteInBackground(const nvi::InputRequest& request, const nvi::Settings& settings,
  const nvi::InputIdentity& identity, vtkImageData* output, vtkTable* log, vtkTable* metrics)
{
  vtkInternals& in = *this->Internals;
  nvi::Preparation* preparing = in.Preparing.get();
  if (preparing && preparing->Identity() == identity)
  {
    if (!preparing->Done())
    {
      return this->EmitWhilePreparing(output, log, metrics);
    }
    return this->AdoptPreparation() && this->EmitOutputs(output, log, metrics);
  }
  if (!preparing && this->IsCurrentTraining(identity))
  {
    return this->EmitOutputs(output, log, metrics);
  }
  // A new input, time or settings: prepared in a thread of its own; the current network stays shown meanwhile.
  nvi::InputRequest copy = request;
  copy.Object.TakeReference(request.Object->NewInstance());
  copy.Object->ShallowCopy(request.Object); // the pipeline may re-execute upstream while the copy is read
  if (request.Array)
  {
    vtkImageData* image = vtkImageData::SafeDownCast(copy.Object);
    vtkDataSetAttributes* attributes = request.Association == vtkDataObject::FIELD_ASSOCIATION_CELLS
      ? static_cast<vtkDataSetAttributes*>(image->GetCellData())
      : static_cast<vtkDataSetAttributes*>(image->GetPointData());
    vtkDataArray* shared = request.ArrayName.empty() ? nullptr : attributes->GetArray(request.ArrayName.c_str());
    copy.Array = shared ? shared : request.Array.GetPointer(); // the same array, shared with the copy
  }
  double bounds[6] = { 1.0, -1.0, 1.0, -1.0, 1.0, -1.0 };
  if (!request.IsImage)
    nvi::InputBounds(request.Object, bounds); // before the work starts: the copy is the thread's afterwards
  in.StopBeforeStart = false; // a Stop asked before this preparation was for the previous one
  in.Preparing.reset(new nvi::Preparation(
    identity,
    [this, copy, settings](nvi::Preparation& self) { return this->PrepareField(copy, settings, self.Result()); },
    std::move(in.Preparing)));
  std::copy(bounds, bounds + 6, in.Preparing->Bounds);
  // A small input is ready within a fraction of a frame: its job starts in this execution, as a blocking one's.
  if (in.Preparing->WaitFor(kPreparationWaitSeconds))
  {
    return this->AdoptPreparation() && this->EmitOutputs(output, log, metrics);
  }
  return this->EmitWhilePreparing(output, log, metrics);
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::AdoptPreparation()
{
  vtkInternals& in = *this->Internals;
  nvi::Preparation& preparation = *in.Preparing;
  for (const nvi::QueuedMessage& message : preparation.TakeMessages())
  {
    this->Report(message.Kind, message.Body);
  }
  if (preparation.Adopted || !preparation.Succeeded())
  {
    preparation.Adopted = true;
    return false; // its error is printed once; the output stays empty until the input or a setting changes
  }
  preparation.Adopted = true;
  nvi::PreparedField& prepared = preparation.Result();
  prepared.Field.PreparationSeconds = preparation.Seconds();
  const nvi::InputIdentity identity = preparation.Identity();
  try
  {
    this->StartJobIfChanged(identity, prepared);
  }
  catch (const nv::Error& e)
  {
    vtkErrorMacro("Neural Compress: " << e.what());
    return false;
  }
  catch (const std::bad_alloc&)
  {
    vtkErrorMacro("Neural Compress: out of memory. Lower Log2TableSize, BatchSize or OutputResolution. The output is "
                  "empty.");
    return false;
  }
  in.Preparing.reset();
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::EmitWhilePreparing(vtkImageData* output, vtkTable* log, vtkTable* metrics)
{
  vtkInternals& in = *this->Internals;
  const std::string status = in.Preparing->StatusLine();
  if (in.Current && this->EmitOutputs(output, log, metrics))
  {
    in.StatusText = status; // the previous input's network stays shown until then
    return true;
  }
  // Nothing to show yet: the promised geometry, no network.
  const double* bounds = in.Preparing->Bounds[0] <= in.Preparing->Bounds[1] ? in.Preparing->Bounds : nullptr;
  nvi::InitializePreparingOutputs(output, log, metrics, this->GetOutputInformation(0), bounds);
  in.StatusText = status;
  return true;
}

