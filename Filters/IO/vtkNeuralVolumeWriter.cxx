#include "vtkNeuralVolumeWriter.h"

#include "vtkNeuralNetworkArray.h"
#include "vtkNeuralVolumeFile.h"

#include "Core/Error.h"
#include "Core/Serialization.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDemandDrivenPipeline.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnsignedCharArray.h"

#include <fstream>
#include <vector>

namespace nvi = vtkNeuralCompressInternals;

struct vtkNeuralVolumeWriter::vtkInternals
{
  std::vector<double> Times;      ///< the input's time steps (WriteAllTimeSteps)
  size_t Next = 0;                ///< the time step written next
  std::vector<nvi::VolumeFileEntry> Entries;
  bool Failed = false;
};

vtkStandardNewMacro(vtkNeuralVolumeWriter);

namespace
{
/// The file entry of one time step of a Neural Compress output: its network, as the filter stored it (the model's
/// own checks run here, before anything is written), and the geometry of its image. Throws nv::Error.
nvi::VolumeFileEntry EntryOf(vtkImageData* image)
{
  vtkUnsignedCharArray* net = image ? vtkNeuralNetworkArray::Find(image->GetFieldData()) : nullptr;
  if (!net || net->GetNumberOfTuples() == 0)
  {
    throw nv::Error("the input has no NeuralNetwork field data array: write the output of Neural Compress "
                    "(apply Neural Compress first)");
  }
  const nv::Model model = vtkNeuralNetworkArray::Read(image->GetFieldData());
  nvi::VolumeFileEntry e;
  e.Time = image->GetInformation()->Has(vtkDataObject::DATA_TIME_STEP())
    ? image->GetInformation()->Get(vtkDataObject::DATA_TIME_STEP())
    : 0.0;
  image->GetExtent(e.Extent);
  image->GetOrigin(e.Origin);
  image->GetSpacing(e.Spacing);
  const double* dir = image->GetDirectionMatrix()->GetData();
  std::copy(dir, dir + 9, e.Direction);
  e.Cells = model.source.association == 1 ? 1 : 0;
  e.Name = model.source.arrayName;
  vtkDataArray* decoded = e.Cells ? image->GetCellData()->GetArray(e.Name.c_str())
                                  : image->GetPointData()->GetArray(e.Name.c_str());
  vtkDataArray* type = vtkDataArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("NeuralSourceType"));
  e.VtkType = decoded ? decoded->GetDataType() : (type ? static_cast<int>(type->GetTuple1(0)) : VTK_FLOAT);
  for (int a = 0; a < 3; ++a)
  {
    e.SourceDims[a] = static_cast<int>(model.source.dims[a]);
    const int n = e.Extent[2 * a + 1] - e.Extent[2 * a] + 1;
    e.DecodedDims[a] = e.Cells ? std::max(1, n - 1) : n;
    e.OnSourceGrid = e.OnSourceGrid && e.DecodedDims[a] == e.SourceDims[a];
  }
  vtkDataArray* range = vtkDataArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("NeuralValueRange"));
  e.ValueRange[0] = range && range->GetNumberOfTuples() >= 2 ? range->GetTuple1(0) : model.source.valueMin;
  e.ValueRange[1] = range && range->GetNumberOfTuples() >= 2 ? range->GetTuple1(1) : model.source.valueMax;
  e.Network.assign(net->GetPointer(0), net->GetPointer(0) + net->GetNumberOfTuples());
  return e;
}

/// The .nvol file of `entries` written to `fileName`. Throws nv::Error.
void WriteEntries(const char* fileName, const std::vector<nvi::VolumeFileEntry>& entries)
{
  const std::vector<uint8_t> bytes = nvi::WriteVolumeFile(entries);
  std::ofstream f(fileName, std::ios::binary);
  if (!f.good())
    throw nv::Error(std::string("cannot open '") + fileName + "' for writing");
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f.good())
    throw nv::Error(std::string("failed writing '") + fileName + "'");
}
} // namespace

vtkNeuralVolumeWriter::vtkNeuralVolumeWriter()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(0);
}

vtkNeuralVolumeWriter::~vtkNeuralVolumeWriter()
{
  this->SetFileName(nullptr);
}

int vtkNeuralVolumeWriter::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkNeuralVolumeWriter::Write()
{
  if (!this->FileName || !*this->FileName)
  {
    vtkErrorMacro("NeuralVolume writer: no file name.");
    return 0;
  }
  if (this->GetNumberOfInputConnections(0) < 1)
  {
    vtkErrorMacro("NeuralVolume writer: no input.");
    return 0;
  }
  vtkInternals& in = *this->Internals;
  in.Entries.clear();
  in.Next = 0;
  in.Failed = false;
  this->Modified();
  this->Update();
  return in.Failed ? 0 : 1;
}

vtkTypeBool vtkNeuralVolumeWriter::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkInternals& in = *this->Internals;
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (request->Has(vtkDemandDrivenPipeline::REQUEST_INFORMATION()))
  {
    in.Times.clear();
    if (inInfo && inInfo->Has(vtkStreamingDemandDrivenPipeline::TIME_STEPS()))
    {
      const double* t = inInfo->Get(vtkStreamingDemandDrivenPipeline::TIME_STEPS());
      in.Times.assign(t, t + inInfo->Length(vtkStreamingDemandDrivenPipeline::TIME_STEPS()));
    }
    return 1;
  }
  if (request->Has(vtkStreamingDemandDrivenPipeline::REQUEST_UPDATE_EXTENT()))
  {
    if (this->WriteAllTimeSteps && !in.Times.empty() && in.Next < in.Times.size())
    {
      inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP(), in.Times[in.Next]);
    }
    return 1;
  }
  if (!request->Has(vtkDemandDrivenPipeline::REQUEST_DATA()))
  {
    return this->Superclass::ProcessRequest(request, inputVector, outputVector);
  }

  vtkImageData* image = vtkImageData::GetData(inputVector[0], 0);
  try
  {
    in.Entries.push_back(EntryOf(image));
  }
  catch (const std::exception& err)
  {
    vtkErrorMacro("NeuralVolume writer: " << err.what() << ". Nothing was written.");
    in.Failed = true;
    request->Remove(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING());
    return 1;
  }

  ++in.Next;
  if (this->WriteAllTimeSteps && in.Next < in.Times.size())
  {
    request->Set(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING(), 1);
    return 1;
  }
  request->Remove(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING());
  try
  {
    WriteEntries(this->FileName, in.Entries);
  }
  catch (const std::exception& err)
  {
    vtkErrorMacro("NeuralVolume writer: " << err.what() << ".");
    in.Failed = true;
  }
  return 1;
}

void vtkNeuralVolumeWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n"
     << indent << "WriteAllTimeSteps: " << this->WriteAllTimeSteps << "\n";
}
