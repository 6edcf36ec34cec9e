#include "vtkNeuralVolumeRepresentation.h"

#include "vtkNeuralNetworkArray.h"
#include "vtkNeuralVolumeMapper.h"

#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkObjectFactory.h"

#include <algorithm>

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
void vtkNeuralVolumeRepresentation::SetProgressiveRefinement(int progressive)
{
  this->NeuralMapper->SetProgressiveRefinement(progressive != 0);
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
int* vtkNeuralVolumeRepresentation::GetLastImageSize()
{
  this->NeuralMapper->GetLastImageSize(this->LastImageSize);
  return this->LastImageSize;
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
int vtkNeuralVolumeRepresentation::RequestData(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  const int ok = this->Superclass::RequestData(request, inputVector, outputVector);
  this->HasNetwork = 0;
  if (inputVector[0]->GetNumberOfInformationObjects() == 1)
  {
    vtkImageData* image = vtkImageData::GetData(inputVector[0], 0);
    // Under MPI, Neural Compress gives its whole output (and the network) to rank 0 and an empty image to the
    // other ranks: an empty piece has nothing to draw and is no error.
    vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
    const bool emptyPiece = image && image->GetNumberOfPoints() == 0 && controller &&
      controller->GetNumberOfProcesses() > 1;
    if (image && vtkNeuralNetworkArray::Find(image->GetFieldData()))
    {
      this->HasNetwork = 1;
      this->ReportedMissing = false;
    }
    else if (!this->ReportedMissing && !emptyPiece)
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
void vtkNeuralVolumeRepresentation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "HasNetwork: " << this->HasNetwork << "\n";
}
