#include "vtkNeuralVolumeReader.h"

#include "vtkNeuralCompressDecode.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralVolumeFile.h"

#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"

#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <cstring>
#include <fstream>
#include <vector>

namespace nvi = vtkNeuralCompressInternals;

struct vtkNeuralVolumeReader::vtkInternals
{
  std::vector<nvi::VolumeFileEntry> Entries; ///< of the file read by the last RequestInformation (empty: error)
  std::string FailedName;                    ///< a file that failed, reported once while it stays the same
  std::vector<uint8_t> FailedBytes;
};

const char* vtkNeuralVolumeReader::GetArrayName()
{
  return this->Internals->Entries.empty() ? "" : this->Internals->Entries[0].Name.c_str();
}

int vtkNeuralVolumeReader::GetArrayAssociation()
{
  return this->Internals->Entries.empty() ? 0 : this->Internals->Entries[0].Cells;
}

vtkStandardNewMacro(vtkNeuralVolumeReader);

vtkNeuralVolumeReader::vtkNeuralVolumeReader()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(0);
}

vtkNeuralVolumeReader::~vtkNeuralVolumeReader()
{
  this->SetFileName(nullptr);
}

int vtkNeuralVolumeReader::CanReadFile(const char* name)
{
  std::ifstream f(name ? name : "", std::ios::binary);
  char magic[8] = {};
  f.read(magic, 8);
  return f.gcount() == 8 && std::memcmp(magic, "NVOLFILE", 8) == 0 ? 1 : 0;
}

int vtkNeuralVolumeReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  std::vector<nvi::VolumeFileEntry>& entries = this->Internals->Entries;
  entries.clear();
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_STEPS());
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_RANGE());
  std::vector<uint8_t> bytes;
  try
  {
    if (!this->FileName || !*this->FileName)
      throw nv::Error("no file name");
    bytes = nvi::ReadFileBytes(this->FileName);
    entries = nvi::ReadVolumeFile(bytes.data(), bytes.size());
    for (const nvi::VolumeFileEntry& e : entries)
    {
      if (!std::equal(e.Extent, e.Extent + 6, entries[0].Extent))
        throw nv::Error("the time steps of the file have different extents");
      // The network's own format, version and checksum; the image the entry states is its network's.
      nvi::CheckEntryAgainstNetwork(e, nv::deserialize(e.Network).source);
    }
  }
  catch (const std::exception& err)
  {
    // Reported once for a file that stays the same (the pipeline asks for information repeatedly).
    const std::string name = this->FileName ? this->FileName : "";
    if (name != this->Internals->FailedName || bytes != this->Internals->FailedBytes)
    {
      vtkErrorMacro("NeuralVolume reader: '" << name << "': " << err.what() << ". The output is empty.");
    }
    this->Internals->FailedName = name;
    this->Internals->FailedBytes = std::move(bytes);
    entries.clear();
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    return 1;
  }
  this->Internals->FailedName.clear();
  this->Internals->FailedBytes.clear();
  const nvi::VolumeFileEntry& e = entries[0];
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), e.Extent, 6);
  outInfo->Set(vtkDataObject::ORIGIN(), e.Origin, 3);
  outInfo->Set(vtkDataObject::SPACING(), e.Spacing, 3);
  outInfo->Set(vtkDataObject::DIRECTION(), e.Direction, 9);
  if (entries.size() > 1)
  {
    std::vector<double> times;
    for (const nvi::VolumeFileEntry& x : entries)
      times.push_back(x.Time);
    outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_STEPS(), times.data(), static_cast<int>(times.size()));
    const double range[2] = { times.front(), times.back() };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_RANGE(), range, 2);
  }
  return 1;
}

int vtkNeuralVolumeReader::RequestData(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkImageData* output = vtkImageData::GetData(outputVector, 0);
  output->Initialize();
  const std::vector<nvi::VolumeFileEntry>& entries = this->Internals->Entries;
  if (entries.empty())
  {
    return 1; // the error was reported by RequestInformation
  }
  // The entry of the requested time: the last one at or before it (the first one before all).
  size_t k = 0;
  if (outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP()))
  {
    const double t = outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP());
    for (size_t i = 0; i < entries.size(); ++i)
      if (entries[i].Time <= t)
        k = i;
  }
  const nvi::VolumeFileEntry& e = entries[k];
  try
  {
    const nv::Model model = nv::deserialize(e.Network);
    nvi::FieldInfo f;
    f.Name = e.Name;
    f.Cells = e.Cells != 0;
    f.VtkType = e.VtkType;
    std::copy(e.Extent, e.Extent + 6, f.Geometry.Extent);
    std::copy(e.Origin, e.Origin + 3, f.Geometry.Origin);
    std::copy(e.Spacing, e.Spacing + 3, f.Geometry.Spacing);
    std::copy(e.SourceDims, e.SourceDims + 3, f.Geometry.SourceDims);
    std::copy(e.DecodedDims, e.DecodedDims + 3, f.Geometry.DecodedDims);
    f.Geometry.OnSourceGrid = e.OnSourceGrid != 0;
    std::copy(e.Direction, e.Direction + 9, f.Direction);
    f.Stats.min = e.ValueRange[0];
    f.Stats.max = e.ValueRange[1];
    const int64_t samples = model.source.dims[0] * model.source.dims[1] * model.source.dims[2];
    if (!model.source.domain.empty())
    {
      // The decoded field is NaN outside the source's domain, as the filter's was.
      auto outside = std::make_shared<std::vector<uint8_t>>(size_t(samples), uint8_t(0));
      for (int64_t i = 0; i < samples; ++i)
        (*outside)[size_t(i)] = ((model.source.domain[size_t(i >> 5)] >> (i & 31)) & 1u) ? 0 : 1;
      f.Outside = outside;
    }
    nvi::NetworkRecord record;
    record.Time = e.Time;
    record.Bytes = nvi::ShareBytes(e.Network);
    record.Figures = nvi::MetricsOf(model, model.stats.device);
    record.Figures.State = "Loaded";
    record.Figures.Restored = true;
    vtkSmartPointer<vtkDataArray> decoded;
    if (this->OutputMode != 0)
    {
      const nv::Device device = nv::resolveDevice(static_cast<nv::Device>(this->Device));
      std::shared_ptr<nv::NetworkSession> session = nv::NetworkSession::create(device, model);
      decoded = nvi::DecodeOutput(*session, f, this->OutputMode);
    }
    nvi::FillImage(output, f, record, decoded, nullptr, false);
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), e.Time);
  }
  catch (const std::exception& err)
  {
    vtkErrorMacro("NeuralVolume reader: '" << this->FileName << "': " << err.what() << ". The output is empty.");
    output->Initialize();
  }
  return 1;
}

void vtkNeuralVolumeReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n"
     << indent << "OutputMode: " << this->OutputMode << "\n"
     << indent << "Device: " << this->Device << "\n";
}

int vtkNeuralVolumeReader::GetGpuUsable()
{
  return nv::cudaAvailable() ? 1 : 0;
}
