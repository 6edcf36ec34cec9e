#include "vtkNeuralVolumeRepresentation.h"

#include "vtkNeuralVolumeMapper.h"

#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiBlockVolumeMapper.h"
#include "vtkObjectFactory.h"
#include "vtkUnsignedCharArray.h"

vtkStandardNewMacro(vtkNeuralVolumeRepresentation);

//------------------------------------------------------------------------------
vtkNeuralVolumeRepresentation::vtkNeuralVolumeRepresentation()
{
  // Swap the stock mapper for ours; everything else (delivery, outline, transfer functions,
  // blend mode, cropping) stays with vtkImageVolumeRepresentation.
  this->VolumeMapper = this->NeuralMapper.GetPointer();
}

vtkNeuralVolumeRepresentation::~vtkNeuralVolumeRepresentation() = default;

vtkNeuralVolumeMapper* vtkNeuralVolumeRepresentation::GetNeuralMapper()
{
  return this->NeuralMapper;
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeRepresentation::SetDecodeResolution(int x, int y, int z)
{
  this->NeuralMapper->SetDecodeResolution(x, y, z);
}

void vtkNeuralVolumeRepresentation::SetSlicesPerRender(int slices)
{
  this->NeuralMapper->SetSlicesPerRender(slices);
}

int vtkNeuralVolumeRepresentation::GetDecodedSlices()
{
  return this->NeuralMapper->GetDecodedSlices();
}

int vtkNeuralVolumeRepresentation::GetTotalSlices()
{
  return this->NeuralMapper->GetTotalSlices();
}

int vtkNeuralVolumeRepresentation::GetDecodeCount()
{
  return this->NeuralMapper->GetDecodeCount();
}

void vtkNeuralVolumeRepresentation::SetRequestedRenderMode(int mode)
{
  this->Superclass::SetRequestedRenderMode(mode);
  this->NeuralMapper->GetRenderMapper()->SetRequestedRenderMode(mode);
}

void vtkNeuralVolumeRepresentation::SetRenderPath(int path)
{
  if (path < DECODE || path > IN_SHADER)
  {
    vtkErrorMacro("Neural Volume: unknown render path " << path << "; using Decode.");
    path = DECODE;
  }
  if (path != DECODE)
  {
    vtkWarningMacro("Neural Volume: the '"
      << (path == SAMPLE_STREAMING ? "Sample Streaming" : "In-Shader")
      << "' render path arrives in a later version of NeuralVolume; rendering with Decode.");
  }
  if (path != this->RenderPath)
  {
    this->RenderPath = path;
    this->Modified();
  }
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
    vtkUnsignedCharArray* network = image
      ? vtkUnsignedCharArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("NeuralNetwork"))
      : nullptr;
    if (network && network->GetNumberOfTuples() > 0)
    {
      this->HasNetwork = 1;
    }
    else
    {
      vtkErrorMacro("Neural Volume: the input has no 'NeuralNetwork' field data array, so there "
                    "is no network to render. Apply the Neural Compress filter (Filters > Neural) "
                    "and show its output with the Neural Volume representation. Nothing is "
                    "rendered.");
    }
  }
  return ok;
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeRepresentation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "RenderPath: " << this->RenderPath << "\n";
  os << indent << "HasNetwork: " << this->HasNetwork << "\n";
}
