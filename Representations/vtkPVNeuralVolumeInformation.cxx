#include "vtkPVNeuralVolumeInformation.h"

#include "vtkNeuralVolumeRepresentation.h"

#include "vtkClientServerStream.h"
#include "vtkObjectFactory.h"

vtkStandardNewMacro(vtkPVNeuralVolumeInformation);

vtkPVNeuralVolumeInformation::vtkPVNeuralVolumeInformation()
{
  this->RootOnly = 1;
}

vtkPVNeuralVolumeInformation::~vtkPVNeuralVolumeInformation() = default;

void vtkPVNeuralVolumeInformation::CopyFromObject(vtkObject* object)
{
  auto* representation = vtkNeuralVolumeRepresentation::SafeDownCast(object);
  this->Valid = representation != nullptr;
  if (!representation)
  {
    return;
  }
  this->HasNetwork = representation->GetMapperHasNetwork() != 0;
  this->WorkPending = representation->GetWorkPending() != 0;
  this->EngineRenderCount = representation->GetEngineRenderCount();
  this->RenderPath = representation->GetLastRenderPath();
  this->AccumulatedFrames = representation->GetLastAccumulatedFrames();
  this->SamplesEvaluated = representation->GetLastSamplesEvaluated();
  this->SessionFromBytes = representation->GetSessionFromBytes() != 0;
}

void vtkPVNeuralVolumeInformation::AddInformation(vtkPVInformation* other)
{
  auto* info = vtkPVNeuralVolumeInformation::SafeDownCast(other);
  if (info && info->Valid && !this->Valid)
  {
    this->Valid = true;
    this->HasNetwork = info->HasNetwork;
    this->WorkPending = info->WorkPending;
    this->EngineRenderCount = info->EngineRenderCount;
    this->RenderPath = info->RenderPath;
    this->AccumulatedFrames = info->AccumulatedFrames;
    this->SamplesEvaluated = info->SamplesEvaluated;
    this->SessionFromBytes = info->SessionFromBytes;
  }
}

void vtkPVNeuralVolumeInformation::CopyToStream(vtkClientServerStream* stream)
{
  stream->Reset();
  *stream << vtkClientServerStream::Reply << (this->Valid ? 1 : 0) << (this->HasNetwork ? 1 : 0)
          << (this->WorkPending ? 1 : 0) << this->EngineRenderCount << this->RenderPath
          << this->AccumulatedFrames << this->SamplesEvaluated << (this->SessionFromBytes ? 1 : 0)
          << vtkClientServerStream::End;
}

void vtkPVNeuralVolumeInformation::CopyFromStream(const vtkClientServerStream* stream)
{
  int valid = 0, network = 0, pending = 0, fromBytes = 0;
  stream->GetArgument(0, 0, &valid);
  stream->GetArgument(0, 1, &network);
  stream->GetArgument(0, 2, &pending);
  stream->GetArgument(0, 3, &this->EngineRenderCount);
  stream->GetArgument(0, 4, &this->RenderPath);
  stream->GetArgument(0, 5, &this->AccumulatedFrames);
  stream->GetArgument(0, 6, &this->SamplesEvaluated);
  stream->GetArgument(0, 7, &fromBytes);
  this->Valid = valid != 0;
  this->HasNetwork = network != 0;
  this->WorkPending = pending != 0;
  this->SessionFromBytes = fromBytes != 0;
}

void vtkPVNeuralVolumeInformation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Valid: " << this->Valid << "\n"
     << indent << "HasNetwork: " << this->HasNetwork << "\n"
     << indent << "WorkPending: " << this->WorkPending << "\n"
     << indent << "EngineRenderCount: " << this->EngineRenderCount << "\n"
     << indent << "RenderPath: " << this->RenderPath << "\n"
     << indent << "AccumulatedFrames: " << this->AccumulatedFrames << "\n"
     << indent << "SamplesEvaluated: " << this->SamplesEvaluated << "\n"
     << indent << "SessionFromBytes: " << this->SessionFromBytes << "\n";
}
