// A rank's piece of an image input under MPI (vtkNeuralCompressPartition.h).
#include "vtkNeuralCompressPartition.h"

#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCudaDevice.h"

#include "vtkDoubleArray.h"
#include "vtkExtentTranslator.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <unistd.h> // gethostname

namespace vtkNeuralCompressInternals
{
namespace
{
/// This rank's block of the whole extent's cells (as point extent), grown by `ghosts` layers (clamped to the
/// whole extent); false when the block is empty.
bool PieceExtent(const int whole[6], int ghosts, int piece[6])
{
  vtkMultiProcessController* c = DistributedController();
  int w[6];
  std::copy(whole, whole + 6, w);
  vtkNew<vtkExtentTranslator> translator;
  return c &&
    translator->PieceToExtentThreadSafe(c->GetLocalProcessId(), c->GetNumberOfProcesses(), ghosts, w, piece,
      vtkExtentTranslator::BLOCK_MODE, 0) != 0 &&
    piece[0] <= piece[1] && piece[2] <= piece[3] && piece[4] <= piece[5];
}

bool Contains(const int outer[6], const int inner[6])
{
  for (int a = 0; a < 3; ++a)
    if (inner[2 * a] < outer[2 * a] || inner[2 * a + 1] > outer[2 * a + 1])
      return false;
  return true;
}

bool Intersect(const int a[6], const int b[6], int out[6])
{
  for (int i = 0; i < 3; ++i)
  {
    out[2 * i] = std::max(a[2 * i], b[2 * i]);
    out[2 * i + 1] = std::min(a[2 * i + 1], b[2 * i + 1]);
    if (out[2 * i] > out[2 * i + 1])
      return false;
  }
  return true;
}
} // namespace

//------------------------------------------------------------------------------
bool PerRankNetworks(vtkDataObject* input)
{
  return DistributedController() && vtkImageData::SafeDownCast(input);
}

namespace
{
HostRanks KnownHost;       ///< RanksOnThisHost's answer, once known
bool HostKnown = false;
} // namespace

int KnownRanksOnThisHost()
{
  return HostKnown ? KnownHost.Count : 1;
}

HostRanks RanksOnThisHost()
{
  HostRanks& host = KnownHost;
  bool& known = HostKnown;
  if (known)
    return host;
  vtkMultiProcessController* c = DistributedController();
  if (!c)
    return HostRanks();
  constexpr int kNameLength = 256;
  char name[kNameLength] = {};
  gethostname(name, kNameLength - 1);
  std::vector<char> all(static_cast<size_t>(kNameLength) * c->GetNumberOfProcesses());
  c->AllGather(name, all.data(), kNameLength);
  host.Count = 0;
  for (int r = 0; r < c->GetNumberOfProcesses(); ++r)
  {
    if (std::strncmp(all.data() + static_cast<size_t>(r) * kNameLength, name, kNameLength) != 0)
      continue;
    if (r < c->GetLocalProcessId())
      ++host.Index;
    ++host.Count;
  }
  host.Count = std::max(host.Count, 1);
  vtkNeuralCudaDevice::ChooseForLocalRank(host.Index); // the GPU of this local rank, for every session made here
  known = true;
  return host;
}

void ImagePiece::RequestPaddedPiece(vtkInformation* inInfo)
{
  if (!inInfo || !inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    return;
  int whole[6], padded[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  if (!PieceExtent(whole, kPieceGhostLayers, padded))
  {
    // No piece for this rank (more ranks than cells): an empty request.
    const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    std::copy(empty, empty + 6, padded);
  }
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), padded, 6);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), 0);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), 1);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
}

bool ImagePiece::Select(vtkImageData* local, const int wholeExtent[6])
{
  this->TrainingImage = nullptr;
  std::copy(wholeExtent, wholeExtent + 6, this->WholeExtent);
  int owned[6], padded[6], have[6];
  if (!local || local->GetNumberOfPoints() == 0 || !PieceExtent(wholeExtent, 0, owned) ||
    !PieceExtent(wholeExtent, kPieceGhostLayers, padded))
    return false;
  local->GetExtent(have);
  // A producer that gave less than the padded piece: what it gave (the seams then rest on fewer ghost layers).
  if (!Intersect(owned, have, this->OwnedExtent) || !Intersect(padded, have, padded))
    return false;
  if (Contains(padded, have))
  {
    this->TrainingImage = local;
    return true;
  }
  // A producer that gave more (the whole extent, say): only the padded piece is trained on.
  this->TrainingImage = vtkSmartPointer<vtkImageData>::New();
  this->TrainingImage->ShallowCopy(local);
  this->TrainingImage->Crop(padded);
  return true;
}

void ImagePiece::Adopt(vtkImageData* training, const int owned[6], const int wholeExtent[6])
{
  this->TrainingImage = training;
  std::copy(owned, owned + 6, this->OwnedExtent);
  std::copy(wholeExtent, wholeExtent + 6, this->WholeExtent);
}

void ImagePiece::CropOutput(vtkImageData* output) const
{
  if (!output || output->GetNumberOfPoints() == 0 || !this->TrainingImage)
    return;
  // The owned piece's bounds in the index-aligned frame of the input (origin + index * spacing), the frame of the
  // network's source bounds; the output samples the same frame with its own origin and spacing.
  const double* inOrigin = this->TrainingImage->GetOrigin();
  const double* inSpacing = this->TrainingImage->GetSpacing();
  const double* outOrigin = output->GetOrigin();
  const double* outSpacing = output->GetSpacing();
  int outExtent[6], crop[6];
  output->GetExtent(outExtent);
  vtkNew<vtkDoubleArray> bounds;
  bounds->SetName("NeuralPieceBounds");
  bounds->SetNumberOfTuples(6);
  for (int a = 0; a < 3; ++a)
  {
    const double lo = inOrigin[a] + this->OwnedExtent[2 * a] * inSpacing[a];
    const double hi = inOrigin[a] + this->OwnedExtent[2 * a + 1] * inSpacing[a];
    bounds->SetValue(2 * a, std::min(lo, hi));
    bounds->SetValue(2 * a + 1, std::max(lo, hi));
    crop[2 * a] = outExtent[2 * a];
    crop[2 * a + 1] = outExtent[2 * a + 1];
    // An axis resampled by OutputResolution holds this piece's part of the whole output lattice already
    // (PieceOfWholeGeometry): only an axis on the input's own lattice is cropped.
    const double slack = 1e-9 * std::max(std::fabs(inSpacing[a]), 1e-300);
    const bool inputLattice =
      std::fabs(outSpacing[a] - inSpacing[a]) <= slack && std::fabs(outOrigin[a] - inOrigin[a]) <= slack;
    if (inputLattice && outSpacing[a] != 0.0 && outExtent[2 * a + 1] > outExtent[2 * a])
    {
      // The output samples within the piece (both ends: neighbouring pieces share their boundary plane).
      const double i0 = (lo - outOrigin[a]) / outSpacing[a], i1 = (hi - outOrigin[a]) / outSpacing[a];
      crop[2 * a] = std::max(outExtent[2 * a], static_cast<int>(std::ceil(std::min(i0, i1) - 1e-6)));
      crop[2 * a + 1] = std::min(outExtent[2 * a + 1], static_cast<int>(std::floor(std::max(i0, i1) + 1e-6)));
    }
  }
  output->Crop(crop);
  output->GetFieldData()->AddArray(bounds);
}

} // namespace vtkNeuralCompressInternals
