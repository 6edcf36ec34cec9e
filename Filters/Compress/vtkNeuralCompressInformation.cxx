// vtkNeuralCompress::RequestInformation: the output's whole extent (origin, spacing, direction) announced before
// any training -- an image's decoded at OutputResolution, a resampled input's from its sampling dimensions, a sparse
// grid's index box, or the whole input's under MPI.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressDataSetPiece.h"
#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressSparse.h"
#include "vtkNeuralCompressState.h"

#include "vtkAlgorithmOutput.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataSet.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkPolyData.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <functional>
#include <string>

namespace
{
bool IsCellAssociation(vtkInformation* arrayInfo)
{
  return arrayInfo && arrayInfo->Has(vtkDataObject::FIELD_ASSOCIATION()) &&
    arrayInfo->Get(vtkDataObject::FIELD_ASSOCIATION()) == vtkDataObject::FIELD_ASSOCIATION_CELLS;
}

/// A sparse OpenVDB grid's output covers its index box (no whole extent when the grid does not read).
void AnnounceSparseExtent(
  vtkDataObject* input, vtkInformation* outInfo, const int outputResolution[3], int finest, int base)
{
  nvi::SparseVoxels voxels;
  std::string problem;
  if (nvi::ReadSparseVoxels(input, nvi::SparseScalarsName(input), voxels, problem))
  {
    const int ext[6] = { 0, voxels.Dims[0] - 1, 0, voxels.Dims[1] - 1, 0, voxels.Dims[2] - 1 };
    const nvi::OutputGeometry g =
      nvi::ComputeGeometry(ext, voxels.Origin, voxels.Spacing, false, outputResolution, finest, base);
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), g.Extent, 6);
  }
  else
  {
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
  }
}

/// An image input's output: its whole extent, origin and spacing decoded at `outputResolution`, its direction.
void AnnounceImageGeometry(
  vtkInformation* inInfo, vtkInformation* outInfo, bool cells, const int outputResolution[3], int finest, int base)
{
  int ext[6];
  double origin[3] = { 0, 0, 0 }, spacing[3] = { 1, 1, 1 };
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext);
  if (inInfo->Has(vtkDataObject::ORIGIN()))
  {
    inInfo->Get(vtkDataObject::ORIGIN(), origin);
  }
  if (inInfo->Has(vtkDataObject::SPACING()))
  {
    inInfo->Get(vtkDataObject::SPACING(), spacing);
  }
  const nvi::OutputGeometry g = nvi::ComputeGeometry(ext, origin, spacing, cells, outputResolution, finest, base);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), g.Extent, 6);
  outInfo->Set(vtkDataObject::ORIGIN(), g.Origin, 3);
  outInfo->Set(vtkDataObject::SPACING(), g.Spacing, 3);
  if (inInfo->Has(vtkDataObject::DIRECTION()))
  {
    outInfo->CopyEntry(inInfo, vtkDataObject::DIRECTION());
  }
}
} // namespace

//------------------------------------------------------------------------------
int vtkNeuralCompress::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkDataObject* input = inInfo ? inInfo->Get(vtkDataObject::DATA_OBJECT()) : nullptr;
  std::fill(this->Internals->AnnouncedDims, this->Internals->AnnouncedDims + 3, 0);
  if (input && !vtkImageData::SafeDownCast(input))
  {
    if (nvi::DistributedController())
    {
      if (this->AnnounceGridPieces(inInfo, outInfo, input))
        return 1;
      // MPI: the extent follows from the whole input, gathered to rank 0 (vtkNeuralCompressDistributed.h).
      this->Internals->Distributed.Announce(
        this, inInfo, outInfo, this->SamplingDimensions, this->OutputResolution, this->Internals->AnnouncedDims);
      return 1;
    }
    this->AnnounceResampledExtent(inInfo, outInfo, input);
    return 1;
  }
  if (!vtkImageData::SafeDownCast(input) ||
    !inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    return 1;
  }
  AnnounceImageGeometry(inInfo, outInfo, IsCellAssociation(this->GetInputArrayInformation(0)),
    this->OutputResolution, this->FinestResolution, this->BaseResolution);
  return 1;
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::AnnounceResampledExtent(vtkInformation* inInfo, vtkInformation* outInfo, vtkDataObject* input)
{
  // A resampled input: its image's extent follows from the sampling dimensions, which (when automatic) come
  // from the input data; RequestData then resamples at these (see Execute()). ParaView's representations need
  // the extent now, so an input that has not executed yet is brought up to date first.
  vtkAlgorithm* producer = this->GetInputAlgorithm(0, 0);
  const bool empty = vtkDataSet::SafeDownCast(input) ? vtkDataSet::SafeDownCast(input)->GetNumberOfPoints() == 0
    : vtkCompositeDataSet::SafeDownCast(input) ? vtkCompositeDataSet::SafeDownCast(input)->GetNumberOfPoints() == 0
                                               : true;
  if (empty && producer)
  {
    producer->Update(this->GetInputConnection(0, 0)->GetIndex());
    input = inInfo->Get(vtkDataObject::DATA_OBJECT());
  }
  if (nvi::IsSparseVoxels(input))
  {
    AnnounceSparseExtent(input, outInfo, this->OutputResolution, this->FinestResolution, this->BaseResolution);
    return;
  }
  vtkInformation* ai = this->GetInputArrayInformation(0);
  const char* name = ai && ai->Has(vtkDataObject::FIELD_NAME()) ? ai->Get(vtkDataObject::FIELD_NAME()) : nullptr;
  const int assoc =
    ai && ai->Has(vtkDataObject::FIELD_ASSOCIATION()) ? ai->Get(vtkDataObject::FIELD_ASSOCIATION()) : -1;
  int dims[3];
  std::string problem;
  if (name && nvi::ResolveSamplingDimensions(input, name, assoc, this->SamplingDimensions, dims, problem))
  {
    const int ext[6] = { 0, dims[0] - 1, 0, dims[1] - 1, 0, dims[2] - 1 };
    const double origin[3] = { 0, 0, 0 }, spacing[3] = { 1, 1, 1 };
    const nvi::OutputGeometry g = nvi::ComputeGeometry(
      ext, origin, spacing, false, this->OutputResolution, this->FinestResolution, this->BaseResolution);
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), g.Extent, 6);
    std::copy(dims, dims + 3, this->Internals->AnnouncedDims);
  }
  else
  {
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
  }
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::AnnounceGridPieces(vtkInformation* inInfo, vtkInformation* outInfo, vtkDataObject* input)
{
  vtkInternals& in = *this->Internals;
  if (!nvi::PerRankDataSetType(input))
  {
    in.GridPieces = in.ParticlePieces = false; // the same type on every rank: no collective
    return false;
  }
  // A new decision only when every rank sees a change (ParaView changes proxies on every rank together): an
  // execution of one rank alone (a control of a gathered input's run) reaches no collective here.
  vtkInformation* ai = this->GetInputArrayInformation(0);
  const char* name = ai && ai->Has(vtkDataObject::FIELD_NAME()) ? ai->Get(vtkDataObject::FIELD_NAME()) : nullptr;
  const int association =
    ai && ai->Has(vtkDataObject::FIELD_ASSOCIATION()) ? ai->Get(vtkDataObject::FIELD_ASSOCIATION()) : -1;
  vtkAlgorithm* producer = this->GetInputAlgorithm(0, 0);
  auto* executive = producer ? vtkStreamingDemandDrivenPipeline::SafeDownCast(producer->GetExecutive()) : nullptr;
  uint64_t stamp = reinterpret_cast<uintptr_t>(producer);
  for (uint64_t v : { uint64_t(executive ? executive->GetPipelineMTime() : 0), uint64_t(association + 2),
         uint64_t(std::hash<std::string>()(name ? name : "")), uint64_t(this->SamplingDimensions[0] + 1),
         uint64_t(this->SamplingDimensions[1] + 1), uint64_t(this->SamplingDimensions[2] + 1) })
    stamp = stamp * 1099511628211ull ^ v;
  if (!in.GridDecided || stamp != in.GridDecisionStamp)
  {
    nvi::UpdateLocalPiece(this, inInfo);
    input = inInfo->Get(vtkDataObject::DATA_OBJECT());
    in.GridPieces = nvi::PerRankDataSets(input);
    // A particle set: its own pieces (vtkNeuralCompressParticlePiece.h), trained as a grid's are.
    in.ParticlePieces = !in.GridPieces && nvi::PerRankParticles(input);
    std::fill(in.GridDims, in.GridDims + 3, 0);
    std::string problem;
    if (in.GridPieces && name && *name &&
      !in.GridPiece.Resolve(input, name, association, this->SamplingDimensions,
        in.GridDims, problem))
      std::fill(in.GridDims, in.GridDims + 3, 0); // RequestData reports it
    if (in.ParticlePieces && name && *name &&
      !in.Particles.Resolve(input, name, association, this->SamplingDimensions, ParticleSettingsOf(this),
        in.GridDims, problem))
      std::fill(in.GridDims, in.GridDims + 3, 0);
    in.GridPieces = in.GridPieces || in.ParticlePieces;
    in.GridDecided = true;
    in.GridDecisionStamp = stamp;
  }
  if (!in.GridPieces)
    return false;
  if (in.GridDims[0] <= 0)
  {
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    return true;
  }
  const int ext[6] = { 0, in.GridDims[0] - 1, 0, in.GridDims[1] - 1, 0, in.GridDims[2] - 1 };
  const double origin[3] = { 0, 0, 0 }, spacing[3] = { 1, 1, 1 };
  const nvi::OutputGeometry g = nvi::ComputeGeometry(
    ext, origin, spacing, false, this->OutputResolution, this->FinestResolution, this->BaseResolution);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), g.Extent, 6);
  std::copy(in.GridDims, in.GridDims + 3, in.AnnouncedDims);
  return true;
}
