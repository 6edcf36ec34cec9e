// A rank's lattice samples under MPI (vtkNeuralCompressDataSetPiece.h): every block this rank holds is resampled
// onto every rank's padded region its bounds reach, each region's samples go to its rank, and every lattice point
// keeps the sample of the first block in the composite's order that covers it (the serial vtkResampleToImage's rule).
#include "vtkNeuralCompressDataSetPiece.h"

#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressLatticeBox.h"
#include "vtkNeuralCompressResample.h"

#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkDataArraySelection.h"
#include "vtkDataSet.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkPassSelectedArrays.h"
#include "vtkPointData.h"
#include "vtkResampleToImage.h"

#include <cmath>
#include <limits>

namespace vtkNeuralCompressInternals
{
namespace
{
/// The tag of the pairwise exchange of lattice samples.
constexpr int kExchangeTag = 0x4E565845; // "NVXE"
/// A lattice point no block has covered yet (blocks are ordered by their flat index in the composite).
constexpr double kNoBlock = std::numeric_limits<double>::infinity();

/// One block of this rank with the array: its order in the composite and the lattice points within its bounds.
struct Block
{
  vtkDataSet* Data = nullptr;
  double Order = 0.0;
  LatticeBox Reach{ { 0, -1, 0, -1, 0, -1 } };
  bool Double = false; ///< the array is float64
};

/// The samples of one box of the lattice: per point the order of the block that gave it, then its components.
struct RegionSamples
{
  LatticeBox Extent{ { 0, -1, 0, -1, 0, -1 } };
  int Components = 1;
  std::vector<double> Values;

  void Reset(const LatticeBox& extent, int components)
  {
    this->Extent = extent;
    this->Components = components;
    this->Values.assign(size_t(BoxPoints(extent)) * size_t(components + 1), std::nan(""));
    for (size_t at = 0; at < this->Values.size(); at += size_t(components + 1))
      this->Values[at] = kNoBlock;
  }
  double* At(int i, int j, int k)
  {
    return this->Values.data() + IndexInBox(this->Extent, i, j, k) * (this->Components + 1);
  }
  const double* At(int i, int j, int k) const
  {
    return this->Values.data() + IndexInBox(this->Extent, i, j, k) * (this->Components + 1);
  }

  /// Takes `from`'s samples that come from an earlier block than this one's (ties keep this one); their count.
  int64_t Merge(const RegionSamples& from)
  {
    const LatticeBox part = IntersectBoxes(this->Extent, from.Extent);
    int64_t taken = 0;
    if (IsEmptyBox(part))
      return taken;
    for (int k = part[4]; k <= part[5]; ++k)
      for (int j = part[2]; j <= part[3]; ++j)
        for (int i = part[0]; i <= part[1]; ++i)
        {
          const double* source = from.At(i, j, k);
          double* target = this->At(i, j, k);
          if (!(source[0] < target[0]))
            continue;
          std::copy(source, source + this->Components + 1, target);
          ++taken;
        }
    return taken;
  }
};

/// The lattice (origin, spacing, points per axis, the input's upper bounds) a block is resampled on.
struct LatticeFrame
{
  const double* Origin;
  const double* Spacing;
  const int* Dims;
  const double* Upper;
};

/// This rank's blocks with the array and cells, in the composite's order (a dataset: one block).
std::vector<Block> LocalBlocks(vtkDataObject* local, const std::string& name, int association,
  const LatticeFrame& lattice, const LatticeBox& whole)
{
  std::vector<Block> blocks;
  auto add = [&](vtkDataSet* leaf, unsigned int order) {
    vtkDataArray* array = leaf && leaf->GetNumberOfPoints() > 0 && leaf->GetNumberOfCells() > 0
      ? PieceArray(leaf, name, association) : nullptr;
    if (!array)
      return;
    Block b;
    b.Data = leaf;
    b.Order = double(order);
    b.Double = array->GetDataType() == VTK_DOUBLE;
    double bounds[6];
    leaf->GetBounds(bounds);
    for (int a = 0; a < 3; ++a)
    {
      const double h = lattice.Spacing[a], o = lattice.Origin[a];
      b.Reach[size_t(2 * a)] = lattice.Dims[a] > 1 ? int(std::ceil((bounds[2 * a] - o) / h - 1e-6)) : 0;
      b.Reach[size_t(2 * a + 1)] = lattice.Dims[a] > 1 ? int(std::floor((bounds[2 * a + 1] - o) / h + 1e-6)) : 0;
    }
    b.Reach = IntersectBoxes(b.Reach, whole);
    if (!IsEmptyBox(b.Reach))
      blocks.push_back(b);
  };
  if (auto* ds = vtkDataSet::SafeDownCast(local))
    add(ds, 0);
  else if (auto* cd = vtkCompositeDataSet::SafeDownCast(local))
  {
    vtkSmartPointer<vtkCompositeDataIterator> it;
    it.TakeReference(cd->NewIterator());
    for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
      add(vtkDataSet::SafeDownCast(it->GetCurrentDataObject()), it->GetCurrentFlatIndex());
  }
  return blocks;
}

/// Resamples `block` (vtkResampleToImage, serial on this rank) at the lattice points of `part` into `into` where it
/// is earlier than the block already there. False with `problem` when the resampling gave no values.
bool ResampleBlock(const Block& block, const LatticeBox& part, const LatticeFrame& lattice, const LatticeBox& whole,
  const std::string& name, int association, RegionSamples& into, std::string& problem)
{
  // At least two points along every axis the lattice has more than one (a box one point thick is degenerate).
  LatticeBox box = part;
  for (size_t a = 0; a < 3; ++a)
    if (box[2 * a] == box[2 * a + 1] && whole[2 * a + 1] > whole[2 * a])
      (box[2 * a + 1] < whole[2 * a + 1] ? box[2 * a + 1] : box[2 * a]) += box[2 * a + 1] < whole[2 * a + 1] ? 1 : -1;
  int dims[3];
  double bounds[6];
  for (int a = 0; a < 3; ++a)
  {
    dims[a] = box[size_t(2 * a + 1)] - box[size_t(2 * a)] + 1;
    bounds[2 * a] = lattice.Origin[a] + box[size_t(2 * a)] * lattice.Spacing[a];
    bounds[2 * a + 1] = lattice.Origin[a] + box[size_t(2 * a + 1)] * lattice.Spacing[a];
    if (box[size_t(2 * a + 1)] == lattice.Dims[a] - 1 && lattice.Dims[a] > 1)
      bounds[2 * a + 1] = lattice.Upper[a]; // the last plane exactly on the input's bounds (not a rounding beyond)
  }
  // VTK's serial filters on this rank alone (ParaView's factory would give the parallel resampler, a collective).
  const RootOnlyScope alone(true);
  vtkNew<vtkPassSelectedArrays> pass;
  pass->SetInputDataObject(block.Data);
  pass->GetArraySelection(association)->EnableArray(name.c_str());
  vtkNew<vtkResampleToImage> resample;
  resample->SetInputConnection(pass->GetOutputPort());
  resample->SetUseInputBounds(false);
  resample->SetSamplingBounds(bounds);
  resample->SetSamplingDimensions(dims);
  resample->Update();
  vtkImageData* out = resample->GetOutput();
  vtkDataArray* values = out ? out->GetPointData()->GetArray(name.c_str()) : nullptr;
  vtkDataArray* mask = out ? out->GetPointData()->GetArray(resample->GetMaskArrayName()) : nullptr;
  const int64_t count = BoxPoints(box);
  if (!values || !mask || values->GetNumberOfTuples() != count || mask->GetNumberOfTuples() != count ||
    values->GetNumberOfComponents() != into.Components)
  {
    problem = "resampling this rank's cells gave no '" + name + "' values";
    return false;
  }
  const LatticeBox wanted = IntersectBoxes(part, into.Extent);
  for (int k = wanted[4]; k <= wanted[5]; ++k)
    for (int j = wanted[2]; j <= wanted[3]; ++j)
      for (int i = wanted[0]; i <= wanted[1]; ++i)
      {
        const vtkIdType at = IndexInBox(box, i, j, k);
        double* target = into.At(i, j, k);
        if (mask->GetComponent(at, 0) == 0.0 || !(block.Order < target[0]))
          continue;
        target[0] = block.Order;
        for (int q = 0; q < into.Components; ++q)
          target[1 + q] = values->GetComponent(at, q);
      }
  return true;
}
} // namespace

bool DataSetPiece::SampleRegions(vtkDataObject* local, const std::string& name, int association, std::string& problem)
{
  vtkMultiProcessController* c = DistributedController();
  const int me = c->GetLocalProcessId(), n = c->GetNumberOfProcesses();
  const LatticeFrame lattice{ this->Origin, this->Spacing, this->Dims, this->Upper };
  const std::vector<Block> blocks = LocalBlocks(local, name, association, lattice, this->WholeExtent);
  this->Blocks = int64_t(blocks.size());
  this->Filled = 0;
  bool ok = true;
  // This rank's samples of rank `target`'s padded region (the hull of the parts its blocks reach).
  auto contribute = [&](int target, RegionSamples& samples) {
    const LatticeBox& padded = this->PaddedBoxes[size_t(target)];
    LatticeBox hull{ { 0, -1, 0, -1, 0, -1 } };
    for (const Block& b : blocks)
      hull = HullOfBoxes(hull, IntersectBoxes(b.Reach, padded));
    samples.Reset(hull, this->Components);
    for (const Block& b : blocks)
    {
      const LatticeBox part = IntersectBoxes(b.Reach, padded);
      if (ok && !IsEmptyBox(part))
        ok = ResampleBlock(b, part, lattice, this->WholeExtent, name, association, samples, problem);
    }
  };
  RegionSamples mine;
  const LatticeBox& myPadded = this->PaddedBoxes[size_t(me)];
  if (!IsEmptyBox(myPadded))
  {
    mine.Reset(myPadded, this->Components);
    RegionSamples own;
    contribute(me, own);
    mine.Merge(own);
  }
  auto send = [&](int to) {
    if (IsEmptyBox(this->PaddedBoxes[size_t(to)]))
      return;
    RegionSamples part;
    contribute(to, part);
    c->Send(part.Extent.data(), 6, to, kExchangeTag);
    if (!IsEmptyBox(part.Extent))
      c->Send(part.Values.data(), vtkIdType(part.Values.size()), to, kExchangeTag);
  };
  auto receive = [&](int from) {
    if (IsEmptyBox(myPadded))
      return;
    RegionSamples part;
    c->Receive(part.Extent.data(), 6, from, kExchangeTag);
    if (IsEmptyBox(part.Extent))
      return;
    part.Components = this->Components;
    part.Values.resize(size_t(BoxPoints(part.Extent)) * size_t(this->Components + 1));
    c->Receive(part.Values.data(), vtkIdType(part.Values.size()), from, kExchangeTag);
    this->Filled += mine.Merge(part);
  };
  // Every pair in the same order on every rank (the lower rank sends first): no cycle of waiting sends.
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b)
    {
      if (me == a)
      {
        send(b);
        receive(b);
      }
      else if (me == b)
      {
        receive(a);
        send(a);
      }
    }
  this->TrainingImage = nullptr;
  this->OutsideMask = nullptr;
  if (IsEmptyBox(myPadded) || !ok)
    return ok;
  // The padded region as the training image (float64 when this rank's first block's array is), NaN outside.
  vtkSmartPointer<vtkDataArray> field;
  if (!blocks.empty() && blocks.front().Double)
    field = vtkSmartPointer<vtkDoubleArray>::New();
  else
    field = vtkSmartPointer<vtkFloatArray>::New();
  field->SetName(name.c_str());
  field->SetNumberOfComponents(this->Components);
  const int64_t count = BoxPoints(myPadded);
  field->SetNumberOfTuples(count);
  auto outside = std::make_shared<std::vector<uint8_t>>(size_t(count), uint8_t(0));
  const size_t stride = size_t(this->Components + 1);
  for (vtkIdType at = 0; at < count; ++at)
  {
    const double* sample = mine.Values.data() + size_t(at) * stride;
    for (int q = 0; q < this->Components; ++q)
      field->SetComponent(at, q, sample[1 + q]);
    (*outside)[size_t(at)] = std::isnan(sample[1]) ? 1 : 0;
  }
  this->TrainingImage = vtkSmartPointer<vtkImageData>::New();
  this->TrainingImage->SetExtent(const_cast<int*>(myPadded.data()));
  this->TrainingImage->SetOrigin(this->Origin);
  this->TrainingImage->SetSpacing(this->Spacing);
  this->TrainingImage->GetPointData()->AddArray(field);
  this->OutsideMask = outside;
  return true;
}

} // namespace vtkNeuralCompressInternals
