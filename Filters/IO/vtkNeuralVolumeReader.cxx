#include "vtkNeuralVolumeReader.h"

#include "vtkNeuralCompressDecode.h"
#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressSurroundings.h"
#include "vtkNeuralCudaDevice.h"
#include "vtkNeuralVolumeFile.h"

#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"

#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace nvi = vtkNeuralCompressInternals;

namespace
{
/// Why this process cannot open a file of `pieces` networks (one per rank of a distributed run); empty when it can:
/// at least as many ranks as pieces (rank r draws piece r, ranks beyond the pieces draw nothing).
std::string RankCountProblem(int pieces)
{
  vtkMultiProcessController* c = nvi::DistributedController();
  const int ranks = c ? c->GetNumberOfProcesses() : 1;
  if (pieces == 1 || pieces <= ranks)
    return std::string();
  return "it holds one network per rank of a " + std::to_string(pieces) +
    "-rank run (MPI), each trained on its own piece: open it with " + std::to_string(pieces) + " ranks (mpiexec -n " +
    std::to_string(pieces) + " pvbatch, or a pvserver of " + std::to_string(pieces) + " ranks or more), not " +
    std::to_string(ranks);
}

/// The entry of a time step this process outputs: a serial run's network goes to rank 0 alone (ParaView executes a
/// source that cannot split into pieces on piece 0 only: nothing is drawn twice); piece r of a distributed run's
/// file to rank r (RankCountProblem: opened by at least as many ranks as wrote it).
const nvi::VolumeFileEntry* PieceOfThisRank(const std::vector<const nvi::VolumeFileEntry*>& step)
{
  vtkMultiProcessController* c = nvi::DistributedController();
  const int rank = c ? c->GetLocalProcessId() : 0;
  if (step.front()->Pieces == 1)
    return rank == 0 ? step.front() : nullptr;
  for (const nvi::VolumeFileEntry* e : step)
    if (e->Piece == rank)
      return e;
  return nullptr;
}

/// A piece of a distributed run: the filter decoded its network on the whole grid it was trained on (the piece and
/// its ghost layers: the network's source bounds, sampled at the output's spacing) and cropped that to the piece.
/// The same grid here, so that the decoded piece is the filter's sample for sample. A piece of an output that
/// OutputResolution resampled is the rank's part of the whole output lattice, which the filter decoded at the world
/// positions of its samples (PieceOfWholeGeometry): decoded so here. Throws nv::Error where the grid cannot be
/// recovered.
void PaddedPieceGeometry(
  const nvi::VolumeFileEntry& e, const nv::SourceInfo& source, bool resampledSource, nvi::OutputGeometry& g)
{
  if (e.Cells)
    throw nv::Error("a decoded output of a distributed run's cell array is not supported: use Output Mode "
                    "'Network only' (the Neural Volume representation draws it)");
  nvi::OutputGeometry padded = g;
  bool fits = true;
  for (int a = 0; a < 3; ++a)
  {
    const double spacing = e.Spacing[a], lo = source.bounds[2 * a], hi = source.bounds[2 * a + 1];
    const double first = std::round((lo - e.Origin[a]) / spacing), last = std::round((hi - e.Origin[a]) / spacing);
    const double slack = 1e-6 * std::max(1.0, std::fabs(hi - lo));
    fits = fits && spacing > 0.0 && std::fabs(e.Origin[a] + first * spacing - lo) <= slack &&
      std::fabs(e.Origin[a] + last * spacing - hi) <= slack && first <= e.Extent[2 * a] && last >= e.Extent[2 * a + 1];
    if (!fits)
      break;
    padded.Extent[2 * a] = static_cast<int>(first);
    padded.Extent[2 * a + 1] = static_cast<int>(last);
    padded.DecodedDims[a] = padded.Extent[2 * a + 1] - padded.Extent[2 * a] + 1;
  }
  if (fits)
  {
    g = padded;
    g.OnSourceGrid = std::equal(g.DecodedDims, g.DecodedDims + 3, g.SourceDims);
    return;
  }
  if (resampledSource)
    throw nv::Error("the grid a piece's network was trained on does not fit its image: use Output Mode 'Network only'");
  for (int a = 0; a < 3; ++a)
    g.DecodedDims[a] = e.Extent[2 * a + 1] - e.Extent[2 * a] + 1;
  g.OnSourceGrid = false;
  g.WorldSamples = true; // the entry's own samples (its extent, origin and spacing)
}

/// The field an entry describes: its image, type, range and (a resampled source) the samples outside its domain.
nvi::FieldInfo FieldOfEntry(const nvi::VolumeFileEntry& e, const nv::Model& model)
{
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
  return f;
}

/// NeuralPieceBounds, as Neural Compress gave them to the piece's output (vtkNeuralCompressPartition.h).
void AddPieceBounds(vtkImageData* output, const nvi::VolumeFileEntry& e)
{
  vtkNew<vtkDoubleArray> bounds;
  bounds->SetName("NeuralPieceBounds");
  bounds->SetNumberOfTuples(6);
  for (int i = 0; i < 6; ++i)
    bounds->SetValue(i, e.PieceBounds[i]);
  output->GetFieldData()->AddArray(bounds);
}
} // namespace

struct vtkNeuralVolumeReader::vtkInternals
{
  std::vector<nvi::VolumeFileEntry> Entries; ///< of the file read by the last RequestInformation (empty: error)
  std::string FailedName;                    ///< a file that failed, reported once while it stays the same
  std::vector<uint8_t> FailedBytes;
  /// A distributed run's file opened under MPI: the coarse grid of the whole field that shadows and path tracing
  /// across pieces need (vtkNeuralCompressSurroundings.h), as Neural Compress gives it.
  nvi::Surroundings Surroundings;
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
      if (!std::equal(e.WholeExtent, e.WholeExtent + 6, entries[0].WholeExtent))
        throw nv::Error("the time steps of the file have different extents");
      if (e.Pieces != entries[0].Pieces)
        throw nv::Error("the time steps of the file come from runs of different rank counts");
      // The network's own format, version and checksum; the image the entry states is its network's.
      nvi::CheckEntryAgainstNetwork(e, nv::deserialize(e.Network).source);
    }
    const std::string problem = RankCountProblem(entries[0].Pieces);
    if (!problem.empty())
      throw nv::Error(problem);
  }
  catch (const std::exception& err)
  {
    // Reported once for a file that stays the same (the pipeline asks for information repeatedly).
    const std::string name = this->FileName ? this->FileName : "";
    vtkMultiProcessController* c = nvi::DistributedController();
    const bool reporter = !c || c->GetLocalProcessId() == 0; // under MPI once, not once per rank
    if (reporter && (name != this->Internals->FailedName || bytes != this->Internals->FailedBytes))
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
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), e.WholeExtent, 6);
  // A distributed run's file: every rank outputs its own piece (without this, only piece 0 executes).
  if (e.Pieces > 1)
    outInfo->Set(vtkAlgorithm::CAN_HANDLE_PIECE_REQUEST(), 1);
  else
    outInfo->Remove(vtkAlgorithm::CAN_HANDLE_PIECE_REQUEST());
  outInfo->Set(vtkDataObject::ORIGIN(), e.Origin, 3);
  outInfo->Set(vtkDataObject::SPACING(), e.Spacing, 3);
  outInfo->Set(vtkDataObject::DIRECTION(), e.Direction, 9);
  const auto steps = nvi::EntriesByTime(entries);
  if (steps.size() > 1)
  {
    std::vector<double> times;
    for (const auto& step : steps)
      times.push_back(step.front()->Time);
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
  // The time step requested: the last one at or before it (the first one before all).
  const auto steps = nvi::EntriesByTime(entries);
  size_t k = 0;
  if (outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP()))
  {
    const double t = outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP());
    for (size_t i = 0; i < steps.size(); ++i)
      if (steps[i].front()->Time <= t)
        k = i;
  }
  const nvi::VolumeFileEntry* piece = PieceOfThisRank(steps[k]);
  if (piece)
    this->ReadPiece(*piece, output);
  if (entries[0].Pieces > 1 && nvi::DistributedController())
  {
    // Every rank (one with no piece of the file too): the collective that gives each the whole field's coarse grid.
    std::string problem;
    this->Internals->Surroundings.Update(output->GetNumberOfPoints() > 0 ? output : nullptr, problem);
    if (!problem.empty())
      vtkWarningMacro("NeuralVolume reader: " << problem << "; shadows and path tracing stop at this rank's piece.");
  }
  return 1;
}

void vtkNeuralVolumeReader::ReadPiece(const nvi::VolumeFileEntry& e, vtkImageData* output)
{
  try
  {
    const nv::Model model = nv::deserialize(e.Network);
    nvi::FieldInfo f = FieldOfEntry(e, model);
    if (e.Pieces > 1 && this->OutputMode != 0)
      PaddedPieceGeometry(e, model.source, f.Outside != nullptr, f.Geometry); // cropped to the piece below
    nvi::NetworkRecord record;
    record.Time = e.Time;
    record.Bytes = nvi::ShareBytes(e.Network);
    record.Figures = nvi::MetricsOf(model, model.stats.device);
    record.Figures.State = "Loaded";
    record.Figures.Restored = true;
    vtkSmartPointer<vtkDataArray> decoded;
    if (this->OutputMode != 0)
    {
      nv::SessionOptions options;
      options.cudaDevice = vtkNeuralCudaDevice::Get(); // under MPI: this rank's GPU
      const nv::Device device = nv::resolveDevice(static_cast<nv::Device>(this->Device), nullptr, options.cudaDevice);
      std::shared_ptr<nv::NetworkSession> session = nv::NetworkSession::create(device, model, options);
      decoded = nvi::DecodeOutput(*session, f, this->OutputMode);
    }
    nvi::FillImage(output, f, record, decoded, nullptr, false);
    if (e.Pieces > 1)
    {
      int extent[6];
      std::copy(e.Extent, e.Extent + 6, extent);
      output->Crop(extent); // the piece's own samples (a decoded output was decoded with its ghost layers)
      AddPieceBounds(output, e); // the representation clips this rank's rays to its piece
    }
    output->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), e.Time);
  }
  catch (const std::exception& err)
  {
    vtkErrorMacro("NeuralVolume reader: '" << this->FileName << "': " << err.what() << ". The output is empty.");
    output->Initialize();
  }
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
