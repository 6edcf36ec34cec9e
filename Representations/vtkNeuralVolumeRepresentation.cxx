#include "vtkNeuralVolumeRepresentation.h"

#include "vtkNeuralNetworkArray.h"
#include "vtkNeuralVolumeMapper.h"

#include "vtkCellData.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkObjectFactory.h"
#include "vtkPVView.h"
#include "vtkPointData.h"
#include "vtkStringArray.h"

#include <algorithm>
#include <cmath>
#include <string>

vtkStandardNewMacro(vtkNeuralVolumeRepresentation);

//------------------------------------------------------------------------------
vtkNeuralVolumeRepresentation::vtkNeuralVolumeRepresentation()
{
  // Swap the stock mapper for ours; delivery, outline, transfer functions, blend mode and the
  // volume property stay with vtkImageVolumeRepresentation.
  this->VolumeMapper = this->NeuralMapper.GetPointer();
}

vtkNeuralVolumeRepresentation::~vtkNeuralVolumeRepresentation() = default;

vtkNeuralVolumeMapper* vtkNeuralVolumeRepresentation::GetNeuralMapper()
{
  return this->NeuralMapper;
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeRepresentation::SetRenderPath(int path)
{
  this->NeuralMapper->SetRenderPath(path);
}
void vtkNeuralVolumeRepresentation::SetShadingMode(int mode)
{
  this->NeuralMapper->SetShadingMode(mode);
}
void vtkNeuralVolumeRepresentation::SetSampleDistance(double distance)
{
  this->NeuralMapper->SetSampleDistance(distance);
}
void vtkNeuralVolumeRepresentation::SetStreamingSamples(int k)
{
  this->NeuralMapper->SetStreamingSamples(k);
}
void vtkNeuralVolumeRepresentation::SetSamplesPerPixel(int spp)
{
  this->NeuralMapper->SetSamplesPerPixel(spp);
}
void vtkNeuralVolumeRepresentation::SetMaxBounces(int bounces)
{
  this->NeuralMapper->SetMaxBounces(bounces);
}
void vtkNeuralVolumeRepresentation::SetTargetSamples(int spp)
{
  this->NeuralMapper->SetTargetSamples(spp);
}
void vtkNeuralVolumeRepresentation::SetDenoise(int denoise)
{
  this->NeuralMapper->SetDenoise(denoise != 0);
}
void vtkNeuralVolumeRepresentation::SetFollowViewLight(int follow)
{
  this->NeuralMapper->SetFollowViewLight(follow != 0);
}
void vtkNeuralVolumeRepresentation::SetLightDirection(double x, double y, double z)
{
  this->NeuralMapper->SetLightDirection(x, y, z);
}
void vtkNeuralVolumeRepresentation::SetEmptySpaceSkipping(int skip)
{
  this->NeuralMapper->SetEmptySpaceSkipping(skip != 0);
}
void vtkNeuralVolumeRepresentation::SetDecodeResolution(int x, int y, int z)
{
  this->NeuralMapper->SetDecodeResolution(std::max(0, x), std::max(0, y), std::max(0, z));
}
void vtkNeuralVolumeRepresentation::SetInteractiveImageScale(double scale)
{
  this->NeuralMapper->SetInteractiveImageScale(scale);
}
void vtkNeuralVolumeRepresentation::SetAdaptiveInteractiveScale(int adaptive)
{
  this->NeuralMapper->SetAdaptiveInteractiveScale(adaptive != 0);
}
void vtkNeuralVolumeRepresentation::SetMaximumInteractiveFrameRate(double framesPerSecond)
{
  this->NeuralMapper->SetMaximumInteractiveFrameRate(framesPerSecond);
}
void vtkNeuralVolumeRepresentation::SetProgressiveRefinement(int progressive)
{
  this->NeuralMapper->SetProgressiveRefinement(progressive != 0);
}

void vtkNeuralVolumeRepresentation::SetCudaGLInterop(int interop)
{
  this->NeuralMapper->SetCudaGLInterop(interop != 0);
}

//------------------------------------------------------------------------------
int vtkNeuralVolumeRepresentation::GetLastRenderPath()
{
  return this->NeuralMapper->GetLastRenderPath();
}
double vtkNeuralVolumeRepresentation::GetLastSamplesEvaluated()
{
  return this->NeuralMapper->GetLastSamplesEvaluated();
}
double vtkNeuralVolumeRepresentation::GetLastSamplesPlain()
{
  return this->NeuralMapper->GetLastSamplesPlain();
}
double vtkNeuralVolumeRepresentation::GetLastWavefronts()
{
  return this->NeuralMapper->GetLastWavefronts();
}
int vtkNeuralVolumeRepresentation::GetLastAccumulatedFrames()
{
  return this->NeuralMapper->GetLastAccumulatedFrames();
}
int vtkNeuralVolumeRepresentation::GetLastAccumulatedPaths()
{
  return this->NeuralMapper->GetLastAccumulatedPaths();
}
int* vtkNeuralVolumeRepresentation::GetLastImageSize()
{
  this->NeuralMapper->GetLastImageSize(this->LastImageSize);
  return this->LastImageSize;
}
double* vtkNeuralVolumeRepresentation::GetLastFrameTimings()
{
  this->NeuralMapper->GetLastFrameTimings(this->LastFrameTimings);
  return this->LastFrameTimings;
}
const char* vtkNeuralVolumeRepresentation::GetLastDisplayPath()
{
  return this->NeuralMapper->GetLastDisplayPath();
}
double vtkNeuralVolumeRepresentation::GetLastRenderMilliseconds()
{
  return this->NeuralMapper->GetLastRenderMilliseconds();
}
int vtkNeuralVolumeRepresentation::GetEngineRenderCount()
{
  return this->NeuralMapper->GetEngineRenderCount();
}
int vtkNeuralVolumeRepresentation::GetWorkPending()
{
  return this->NeuralMapper->GetWorkPending() ? 1 : 0;
}
int vtkNeuralVolumeRepresentation::GetSessionFromBytes()
{
  return this->NeuralMapper->GetSessionFromBytes() ? 1 : 0;
}
int vtkNeuralVolumeRepresentation::GetMapperHasNetwork()
{
  return this->NeuralMapper->HasNetwork() ? 1 : 0;
}

//------------------------------------------------------------------------------
namespace
{
/// The input with the network's range under the network's array name (see GetRenderedDataObject), or null when
/// the input needs nothing added (no network, no valid range, or the decoded field is there).
vtkSmartPointer<vtkImageData> WithNetworkRange(vtkImageData* image)
{
  vtkFieldData* fd = image ? image->GetFieldData() : nullptr;
  auto* names = fd ? vtkStringArray::SafeDownCast(fd->GetAbstractArray("NeuralArrayName")) : nullptr;
  vtkDataArray* association = fd ? fd->GetArray("NeuralArrayAssociation") : nullptr;
  vtkDataArray* range = fd ? fd->GetArray("NeuralValueRange") : nullptr;
  if (!names || names->GetNumberOfValues() != 1 || names->GetValue(0).empty() || !range ||
    range->GetNumberOfTuples() != 2 || !vtkNeuralNetworkArray::Find(fd))
  {
    return nullptr;
  }
  const double lo = range->GetTuple1(0), hi = range->GetTuple1(1);
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi || !std::isfinite(hi - lo))
  {
    // No valid value (an empty or all-NaN field), or a range wider than the largest double: ParaView 5.11 aborts when
    // it rescales a colour map to such a range (the network is refused, see the mapper), so none is offered.
    return nullptr;
  }
  const std::string name = names->GetValue(0);
  const bool cells = association && association->GetNumberOfTuples() == 1 && association->GetTuple1(0) == 1;
  vtkDataSetAttributes* attributes =
    cells ? static_cast<vtkDataSetAttributes*>(image->GetCellData()) : image->GetPointData();
  if (attributes->GetAbstractArray(name.c_str()))
  {
    return nullptr; // a decoded output: its own array gives the range
  }
  auto represented = vtkSmartPointer<vtkImageData>::New();
  represented->ShallowCopy(image);
  vtkNew<vtkDoubleArray> values;
  values->SetName(name.c_str());
  values->SetNumberOfTuples(2);
  values->SetValue(0, lo);
  values->SetValue(1, hi);
  (cells ? static_cast<vtkDataSetAttributes*>(represented->GetCellData()) : represented->GetPointData())
    ->AddArray(values);
  return represented;
}
} // namespace

vtkDataObject* vtkNeuralVolumeRepresentation::GetRenderedDataObject(int port)
{
  return this->RepresentedData ? this->RepresentedData.GetPointer() : this->Superclass::GetRenderedDataObject(port);
}

namespace
{
/// Neural Compress is still preparing its field (its output has no network yet, NeuralTrainingState "Preparing"):
/// nothing to draw, and no error to report.
bool IsPreparing(vtkImageData* image)
{
  auto* state =
    image ? vtkStringArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("NeuralTrainingState")) : nullptr;
  return state && state->GetNumberOfValues() > 0 && state->GetValue(0) == "Preparing";
}
} // namespace

//------------------------------------------------------------------------------
int vtkNeuralVolumeRepresentation::RequestData(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  const int ok = this->Superclass::RequestData(request, inputVector, outputVector);
  this->HasNetwork = 0;
  this->RepresentedData = nullptr;
  if (inputVector[0]->GetNumberOfInformationObjects() == 1)
  {
    vtkImageData* image = vtkImageData::GetData(inputVector[0], 0);
    this->RepresentedData = WithNetworkRange(image);
    // Under MPI a rank may hold an empty piece (Neural Compress of an input that is not an image gives its whole
    // output to rank 0; an image piece that a rank does not get): nothing to draw and no error. An image's pieces
    // each carry their rank's network and its piece bounds (NeuralPieceBounds): the mapper clips its rays to them and
    // ParaView composites the ranks in visibility order from the pieces' bounds.
    vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
    const bool emptyPiece = image && image->GetNumberOfPoints() == 0 && controller &&
      controller->GetNumberOfProcesses() > 1;
    if (image && vtkNeuralNetworkArray::Find(image->GetFieldData()))
    {
      this->HasNetwork = 1;
      this->ReportedMissing = false;
    }
    else if (!this->ReportedMissing && !emptyPiece && !IsPreparing(image))
    {
      vtkErrorMacro("Neural Volume: the input has no '"
        << vtkNeuralNetworkArray::GetArrayName()
        << "' field data array, so there is no network to render. Apply the Neural Compress "
           "filter (Filters > Neural) and show its output with the Neural Volume representation. "
           "Nothing is rendered.");
      this->ReportedMissing = true;
    }
  }
  return ok;
}

//------------------------------------------------------------------------------
namespace
{
/// vtkPVView's screenshot flag (set between PrepareForScreenshot and CleanupAfterScreenshot on every process of the
/// view), which ParaView 5.11 keeps protected: read through a member pointer named in a derived class.
struct ScreenshotFlag : vtkPVView
{
  static bool Of(vtkPVView* view) { return view && (view->*(&ScreenshotFlag::GetInCaptureScreenshot))(); }
};
} // namespace

int vtkNeuralVolumeRepresentation::ProcessViewRequest(
  vtkInformationRequestKey* request, vtkInformation* inInfo, vtkInformation* outInfo)
{
  if (request == vtkPVView::REQUEST_RENDER())
  {
    this->NeuralMapper->SetFinalPictureRequired(ScreenshotFlag::Of(vtkPVView::SafeDownCast(this->GetView())));
  }
  return this->Superclass::ProcessViewRequest(request, inInfo, outInfo);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeRepresentation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "HasNetwork: " << this->HasNetwork << "\n";
}
