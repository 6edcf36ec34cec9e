#include "vtkNeuralVolumeWriter.h"

#include "vtkNeuralCompressDistributed.h"
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
#include "vtkMultiProcessController.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <fstream>
#include <string>
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
/// Under MPI, a Neural Compress output that is one rank's piece (field data NeuralPieceBounds, one network per rank):
/// the entry becomes piece `rank` of `ranks` of the input's whole extent.
void SetPiece(nvi::VolumeFileEntry& e, vtkImageData* image, vtkInformation* inInfo)
{
  vtkMultiProcessController* c = nvi::DistributedController();
  vtkDataArray* bounds = vtkDataArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("NeuralPieceBounds"));
  std::copy(e.Extent, e.Extent + 6, e.WholeExtent);
  if (!c || !bounds || bounds->GetNumberOfTuples() * bounds->GetNumberOfComponents() != 6)
    return;
  e.Piece = c->GetLocalProcessId();
  e.Pieces = c->GetNumberOfProcesses();
  for (int i = 0; i < 6; ++i)
    e.PieceBounds[i] = bounds->GetComponent(i / bounds->GetNumberOfComponents(), i % bounds->GetNumberOfComponents());
  if (inInfo && inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), e.WholeExtent);
}

/// The file entry of one time step of a Neural Compress output: its network, as the filter stored it (the model's
/// own checks run here, before anything is written), and the geometry of its image. Throws nv::Error.
nvi::VolumeFileEntry EntryOf(vtkImageData* image, vtkInformation* inInfo)
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
  SetPiece(e, image, inInfo);
  return e;
}

/// Under MPI, an input that holds no piece here (a rank with an empty output: more ranks than pieces, or the
/// ranks other than 0 of an input Neural Compress gathered to rank 0).
bool EmptyRank(vtkImageData* image)
{
  return nvi::DistributedController() && image && image->GetNumberOfPoints() == 0 &&
    !vtkNeuralNetworkArray::Find(image->GetFieldData());
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

/// Under MPI (every rank calls it): every rank's entries to rank 0, which writes the one file (its entries in time,
/// then piece order); the other ranks write nothing. `failed`: this rank could not make its entries (it reported
/// why); then no rank writes. Returns an error message (the same on every rank), empty on success.
std::string WriteGathered(vtkMultiProcessController* c, const char* fileName,
  const std::vector<nvi::VolumeFileEntry>& entries, bool failed)
{
  int localFailed = failed ? 1 : 0, anyFailed = 0;
  c->AllReduce(&localFailed, &anyFailed, 1, vtkCommunicator::MAX_OP);
  if (anyFailed)
    return "a rank could not write its piece (see its message); nothing was written";
  const std::vector<uint8_t> local = entries.empty() ? std::vector<uint8_t>() : nvi::WriteVolumeFile(entries);
  const int ranks = c->GetNumberOfProcesses();
  unsigned long long size = local.size();
  std::vector<unsigned long long> sizes(static_cast<size_t>(ranks), 0);
  c->Gather(&size, sizes.data(), 1, 0);
  std::vector<vtkIdType> lengths(static_cast<size_t>(ranks), 0), offsets(static_cast<size_t>(ranks), 0);
  vtkIdType total = 0;
  for (int r = 0; r < ranks; ++r)
  {
    lengths[static_cast<size_t>(r)] = static_cast<vtkIdType>(sizes[static_cast<size_t>(r)]);
    offsets[static_cast<size_t>(r)] = total;
    total += lengths[static_cast<size_t>(r)];
  }
  std::vector<unsigned char> all(static_cast<size_t>(std::max<vtkIdType>(total, 1)));
  c->GatherV(local.data(), all.data(), static_cast<vtkIdType>(local.size()), lengths.data(), offsets.data(), 0);
  std::string error;
  if (c->GetLocalProcessId() == 0)
  {
    try
    {
      std::vector<nvi::VolumeFileEntry> merged;
      for (int r = 0; r < ranks; ++r)
      {
        if (lengths[static_cast<size_t>(r)] == 0)
          continue;
        std::vector<nvi::VolumeFileEntry> part =
          nvi::ReadVolumeFile(all.data() + offsets[static_cast<size_t>(r)], lengths[static_cast<size_t>(r)]);
        merged.insert(merged.end(), part.begin(), part.end());
      }
      if (merged.empty())
        throw nv::Error("no rank has a NeuralNetwork field data array: write the output of Neural Compress");
      std::stable_sort(merged.begin(), merged.end(), [](const nvi::VolumeFileEntry& a, const nvi::VolumeFileEntry& b) {
        return a.Time < b.Time || (a.Time == b.Time && a.Piece < b.Piece);
      });
      WriteEntries(fileName, merged);
    }
    catch (const std::exception& err)
    {
      error = err.what();
    }
  }
  // Every rank returns rank 0's outcome.
  unsigned long long length = error.size();
  c->Broadcast(&length, 1, 0);
  error.resize(static_cast<size_t>(length));
  if (length > 0)
    c->Broadcast(&error[0], static_cast<vtkIdType>(length), 0);
  return error;
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
  vtkMultiProcessController* c = nvi::DistributedController();
  try
  {
    if (!EmptyRank(image))
      in.Entries.push_back(EntryOf(image, inInfo));
  }
  catch (const std::exception& err)
  {
    vtkErrorMacro("NeuralVolume writer: " << err.what() << ". Nothing was written.");
    in.Failed = true;
    if (!c) // under MPI the ranks still meet below
    {
      request->Remove(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING());
      return 1;
    }
  }

  ++in.Next;
  if (this->WriteAllTimeSteps && in.Next < in.Times.size())
  {
    request->Set(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING(), 1);
    return 1;
  }
  request->Remove(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING());
  if (c)
  {
    // MPI: one file holding every rank's network (vtkNeuralVolumeFile.h, version 2), written by rank 0.
    const bool failedHere = in.Failed;
    const std::string error = WriteGathered(c, this->FileName, in.Entries, in.Failed);
    if (!error.empty() && (!failedHere && c->GetLocalProcessId() == 0))
      vtkErrorMacro("NeuralVolume writer: " << error << ".");
    in.Failed = !error.empty();
    return 1;
  }
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
