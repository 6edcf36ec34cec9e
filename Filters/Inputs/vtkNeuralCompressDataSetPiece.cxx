// A rank's piece of an unstructured grid under MPI (vtkNeuralCompressDataSetPiece.h).
#include "vtkNeuralCompressDataSetPiece.h"

#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressParticles.h"
#include "vtkNeuralCompressPartition.h"
#include "vtkNeuralCompressResample.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataArraySelection.h"
#include "vtkDataSet.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkPassSelectedArrays.h"
#include "vtkPointData.h"
#include "vtkResampleToImage.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace vtkNeuralCompressInternals
{
namespace
{
using Box = std::array<int, 6>;

/// The RMI-free tag of the pairwise exchange of lattice samples.
constexpr int kExchangeTag = 0x4E565845; // "NVXE"

// The summary's layout (DataSetPiece::Summary).
enum SummaryField
{
  kHasCells = 0,   ///< 1: the rank holds cells of its own (not ghosts) and points
  kHasArray = 1,   ///< 1: the array is there (or the rank holds no cells)
  kBounds = 2,     ///< 6: the piece's bounds (ghost cells included)
  kCentres = 8,    ///< 6: the box of its own cells' centres
  kSamples = 14,   ///< its own samples of the array (ghost points / cells left out)
  kBytes = 15,     ///< their bytes
  kComponents = 16 ///< the array's components
};

vtkDataArray* ArrayOf(vtkDataSet* ds, const std::string& name, int association)
{
  return association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? ds->GetCellData()->GetArray(name.c_str())
                                                                : ds->GetPointData()->GetArray(name.c_str());
}

bool Empty(const Box& b)
{
  return b[0] > b[1] || b[2] > b[3] || b[4] > b[5];
}

Box Intersect(const Box& a, const Box& b)
{
  Box o;
  for (int i = 0; i < 3; ++i)
  {
    o[2 * i] = std::max(a[2 * i], b[2 * i]);
    o[2 * i + 1] = std::min(a[2 * i + 1], b[2 * i + 1]);
  }
  return o;
}

Box Grow(const Box& b, int layers, const Box& whole)
{
  Box g = b;
  for (int i = 0; i < 3; ++i)
  {
    g[2 * i] -= layers;
    g[2 * i + 1] += layers;
  }
  return Intersect(g, whole);
}

int64_t Count(const Box& b)
{
  return Empty(b) ? 0 : int64_t(b[1] - b[0] + 1) * (b[3] - b[2] + 1) * (b[5] - b[4] + 1);
}

/// Index of lattice point (i, j, k) in an image of point extent `ext` (x fastest).
int64_t IndexIn(const Box& ext, int i, int j, int k)
{
  return (int64_t(k - ext[4]) * (ext[3] - ext[2] + 1) + (j - ext[2])) * (ext[1] - ext[0] + 1) + (i - ext[0]);
}

/// The k-d tree of the ranks' centre boxes over `region` (see the header): each leaf's point extent into `owned`.
void SplitRegion(const std::vector<DataSetPiece::Summary>& all, std::vector<int> ranks, const Box& region,
  const double origin[3], const double spacing[3], std::vector<Box>& owned)
{
  if (ranks.empty())
    return;
  if (ranks.size() == 1)
  {
    owned[size_t(ranks[0])] = region;
    return;
  }
  const int n = static_cast<int>(ranks.size());
  int bestAxis = -1, bestK = 0;
  double bestGap = -std::numeric_limits<double>::infinity(), bestCut = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    if (region[2 * a + 1] <= region[2 * a])
      continue;
    std::sort(ranks.begin(), ranks.end(), [&all, a](int p, int q) {
      const double cp = all[size_t(p)][kCentres + 2 * a] + all[size_t(p)][kCentres + 2 * a + 1];
      const double cq = all[size_t(q)][kCentres + 2 * a] + all[size_t(q)][kCentres + 2 * a + 1];
      return cp < cq || (cp == cq && p < q);
    });
    std::vector<double> leftHi(static_cast<size_t>(n)), rightLo(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k)
      leftHi[size_t(k)] = std::max(k ? leftHi[size_t(k - 1)] : -std::numeric_limits<double>::infinity(),
        all[size_t(ranks[size_t(k)])][kCentres + 2 * a + 1]);
    for (int k = n - 1; k >= 0; --k)
      rightLo[size_t(k)] = std::min(k < n - 1 ? rightLo[size_t(k + 1)] : std::numeric_limits<double>::infinity(),
        all[size_t(ranks[size_t(k)])][kCentres + 2 * a]);
    for (int k = 1; k < n; ++k)
    {
      // The gap in lattice steps; equal gaps: the more even split, then the lower axis.
      const double gap = (rightLo[size_t(k)] - leftHi[size_t(k - 1)]) / spacing[a];
      const bool better = gap > bestGap + 1e-9 ||
        (gap > bestGap - 1e-9 && std::abs(2 * k - n) < std::abs(2 * bestK - n));
      if (better)
      {
        bestGap = gap;
        bestAxis = a;
        bestK = k;
        bestCut = 0.5 * (rightLo[size_t(k)] + leftHi[size_t(k - 1)]);
      }
    }
  }
  if (bestAxis < 0)
  {
    owned[size_t(*std::min_element(ranks.begin(), ranks.end()))] = region; // a single point: one rank has it
    return;
  }
  const int a = bestAxis;
  std::sort(ranks.begin(), ranks.end(), [&all, a](int p, int q) {
    const double cp = all[size_t(p)][kCentres + 2 * a] + all[size_t(p)][kCentres + 2 * a + 1];
    const double cq = all[size_t(q)][kCentres + 2 * a] + all[size_t(q)][kCentres + 2 * a + 1];
    return cp < cq || (cp == cq && p < q);
  });
  const int plane = std::min(region[2 * a + 1],
    std::max(region[2 * a], static_cast<int>(std::lround((bestCut - origin[a]) / spacing[a]))));
  Box left = region, right = region;
  left[2 * a + 1] = plane;
  right[2 * a] = plane;
  SplitRegion(all, std::vector<int>(ranks.begin(), ranks.begin() + bestK), left, origin, spacing, owned);
  SplitRegion(all, std::vector<int>(ranks.begin() + bestK, ranks.end()), right, origin, spacing, owned);
}
} // namespace

//------------------------------------------------------------------------------
std::vector<std::array<int, 6>> LatticeRegions(const std::vector<std::array<double, 6>>& centres,
  const std::vector<int>& holders, const std::array<int, 6>& whole, const double origin[3], const double spacing[3])
{
  std::vector<DataSetPiece::Summary> all(centres.size());
  for (size_t r = 0; r < centres.size(); ++r)
    std::copy(centres[r].begin(), centres[r].end(), all[r].begin() + kCentres);
  std::vector<Box> owned(centres.size(), Box{ { 0, -1, 0, -1, 0, -1 } });
  SplitRegion(all, holders, whole, origin, spacing, owned);
  return owned;
}

//------------------------------------------------------------------------------
bool PerRankDataSets(vtkDataObject* local)
{
  vtkMultiProcessController* c = DistributedController();
  if (!c)
    return false;
  int mine = vtkUnstructuredGrid::SafeDownCast(local) && !IsParticleSet(local) ? 1 : 0, all = 0;
  c->AllReduce(&mine, &all, 1, vtkCommunicator::MIN_OP);
  return all != 0;
}

//------------------------------------------------------------------------------
DataSetPiece::Summary DataSetPiece::LocalSummary(vtkDataSet* local, const std::string& name, int association)
{
  const uint64_t stamp = InputStamp(local, name, association) ^ (uint64_t(association) << 56);
  if (this->SummaryValid && stamp == this->SummaryStamp)
    return this->Mine;
  Summary s{};
  s[kHasArray] = 1.0;
  s[kComponents] = 1.0;
  vtkUnsignedCharArray* cellGhosts = local ? local->GetCellGhostArray() : nullptr;
  const unsigned char skipCell = vtkDataSetAttributes::DUPLICATECELL | vtkDataSetAttributes::HIDDENCELL;
  double lo[3] = { std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
    std::numeric_limits<double>::infinity() };
  double hi[3] = { -lo[0], -lo[1], -lo[2] };
  int64_t own = 0;
  const vtkIdType cells = local && local->GetNumberOfPoints() > 0 ? local->GetNumberOfCells() : 0;
  for (vtkIdType i = 0; i < cells; ++i)
  {
    if (cellGhosts && (cellGhosts->GetValue(i) & skipCell))
      continue;
    double b[6];
    local->GetCellBounds(i, b);
    for (int a = 0; a < 3; ++a)
    {
      const double centre = 0.5 * (b[2 * a] + b[2 * a + 1]);
      lo[a] = std::min(lo[a], centre);
      hi[a] = std::max(hi[a], centre);
    }
    ++own;
  }
  if (own > 0)
  {
    s[kHasCells] = 1.0;
    double b[6];
    local->GetBounds(b);
    std::copy(b, b + 6, s.begin() + kBounds);
    for (int a = 0; a < 3; ++a)
    {
      s[size_t(kCentres + 2 * a)] = lo[a];
      s[size_t(kCentres + 2 * a + 1)] = hi[a];
    }
    vtkDataArray* array = ArrayOf(local, name, association);
    s[kHasArray] = array ? 1.0 : 0.0;
    if (array)
    {
      const bool onCells = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
      vtkUnsignedCharArray* ghosts = onCells ? cellGhosts : local->GetPointGhostArray();
      const unsigned char skip =
        onCells ? skipCell : (vtkDataSetAttributes::DUPLICATEPOINT | vtkDataSetAttributes::HIDDENPOINT);
      int64_t samples = 0;
      for (vtkIdType i = 0; i < array->GetNumberOfTuples(); ++i)
        samples += ghosts && (ghosts->GetValue(i) & skip) ? 0 : 1;
      s[kSamples] = double(samples);
      s[kBytes] = double(samples) * array->GetNumberOfComponents() * std::max(1, array->GetDataTypeSize());
      s[kComponents] = array->GetNumberOfComponents();
    }
  }
  this->Mine = s;
  this->SummaryStamp = stamp;
  this->SummaryValid = true;
  return s;
}

bool DataSetPiece::Lattice(
  const std::vector<Summary>& all, const std::string& name, const int requested[3], std::string& problem)
{
  double bounds[6] = { 0, -1, 0, -1, 0, -1 };
  double samples = 0.0;
  bool any = false;
  this->Components = 0;
  for (const Summary& s : all)
  {
    if (s[kHasCells] == 0.0)
      continue;
    if (s[kHasArray] == 0.0)
    {
      problem = "no array '" + name + "' on a rank that holds cells";
      return false;
    }
    if (this->Components && this->Components != int(s[kComponents]))
    {
      problem = "array '" + name + "' has different numbers of components on different ranks";
      return false;
    }
    this->Components = int(s[kComponents]);
    for (int a = 0; a < 3; ++a)
    {
      bounds[2 * a] = any ? std::min(bounds[2 * a], s[size_t(kBounds + 2 * a)]) : s[size_t(kBounds + 2 * a)];
      bounds[2 * a + 1] =
        any ? std::max(bounds[2 * a + 1], s[size_t(kBounds + 2 * a + 1)]) : s[size_t(kBounds + 2 * a + 1)];
    }
    samples += s[kSamples];
    any = true;
  }
  if (!any)
  {
    problem = "no rank holds cells of the input";
    return false;
  }
  std::copy(requested, requested + 3, this->Dims);
  if (this->Dims[0] <= 0 || this->Dims[1] <= 0 || this->Dims[2] <= 0)
    AutoSamplingDimensions(bounds, static_cast<int64_t>(samples), 0.0, this->Dims);
  if (double(this->Dims[0]) * this->Dims[1] * this->Dims[2] > 1024.0 * 1024.0 * 1024.0)
  {
    problem = "SamplingDimensions exceed 2^30 samples; choose at most 1024^3";
    return false;
  }
  for (int a = 0; a < 3; ++a)
  {
    // vtkResampleToImage nudges the input's bounds inward by 1e-6 of their size (a point exactly on the boundary
    // may miss every cell): the serial run's lattice.
    const double nudge = 0.5e-6 * (bounds[2 * a + 1] - bounds[2 * a]);
    bounds[2 * a] += nudge;
    bounds[2 * a + 1] -= nudge;
    this->Origin[a] = bounds[2 * a];
    this->Upper[a] = bounds[2 * a + 1];
    this->Spacing[a] = this->Dims[a] > 1 ? (bounds[2 * a + 1] - bounds[2 * a]) / (this->Dims[a] - 1) : 1.0;
    if (!(this->Spacing[a] > 0.0))
      this->Spacing[a] = 1.0;
    this->WholeExtent[size_t(2 * a)] = 0;
    this->WholeExtent[size_t(2 * a + 1)] = this->Dims[a] - 1;
  }
  return true;
}

void DataSetPiece::Regions(const std::vector<Summary>& all)
{
  const Box none{ { 0, -1, 0, -1, 0, -1 } };
  const size_t n = all.size();
  this->OwnedBoxes.assign(n, none);
  this->PaddedBoxes.assign(n, none);
  this->ResampledBoxes.assign(n, none);
  std::vector<int> holders;
  for (size_t r = 0; r < n; ++r)
    if (all[r][kHasCells] != 0.0)
      holders.push_back(static_cast<int>(r));
  SplitRegion(all, holders, this->WholeExtent, this->Origin, this->Spacing, this->OwnedBoxes);
  for (size_t r = 0; r < n; ++r)
  {
    if (Empty(this->OwnedBoxes[r]))
      continue;
    this->PaddedBoxes[r] = Grow(this->OwnedBoxes[r], kPieceGhostLayers, this->WholeExtent);
    // The lattice points within the rank's bounds, at most kExchangeLayers beyond its padded piece.
    Box reach;
    for (int a = 0; a < 3; ++a)
    {
      reach[size_t(2 * a)] = static_cast<int>(std::ceil((all[r][size_t(kBounds + 2 * a)] - this->Origin[a]) /
                                                this->Spacing[a] - 1e-6));
      reach[size_t(2 * a + 1)] = static_cast<int>(std::floor(
        (all[r][size_t(kBounds + 2 * a + 1)] - this->Origin[a]) / this->Spacing[a] + 1e-6));
    }
    reach = Intersect(reach, Grow(this->OwnedBoxes[r], kPieceGhostLayers + kExchangeLayers, this->WholeExtent));
    Box box = this->PaddedBoxes[r];
    if (!Empty(reach))
      for (int a = 0; a < 3; ++a)
      {
        box[size_t(2 * a)] = std::min(box[size_t(2 * a)], reach[size_t(2 * a)]);
        box[size_t(2 * a + 1)] = std::max(box[size_t(2 * a + 1)], reach[size_t(2 * a + 1)]);
      }
    this->ResampledBoxes[r] = box;
  }
}

bool DataSetPiece::Resample(vtkDataSet* local, const std::string& name, int association, std::string& problem)
{
  vtkMultiProcessController* c = DistributedController();
  Box box = this->ResampledBoxes[size_t(c->GetLocalProcessId())];
  this->ResampledImage = nullptr;
  if (Empty(box))
    return true;
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetExtent(box.data());
  image->SetOrigin(this->Origin);
  image->SetSpacing(this->Spacing);
  vtkSmartPointer<vtkDataArray> field;
  int dims[3];
  double bounds[6];
  for (int a = 0; a < 3; ++a)
  {
    dims[a] = box[size_t(2 * a + 1)] - box[size_t(2 * a)] + 1;
    bounds[2 * a] = this->Origin[a] + box[size_t(2 * a)] * this->Spacing[a];
    bounds[2 * a + 1] = this->Origin[a] + box[size_t(2 * a + 1)] * this->Spacing[a];
    if (box[size_t(2 * a + 1)] == this->Dims[a] - 1 && this->Dims[a] > 1)
      bounds[2 * a + 1] = this->Upper[a]; // the last plane exactly on the input's bounds (not a rounding beyond)
  }
  vtkSmartPointer<vtkDataArray> values, mask;
  {
    // VTK's serial filters on this rank alone (ParaView's factory would give the parallel resampler, a collective).
    const RootOnlyScope alone(true);
    vtkNew<vtkPassSelectedArrays> pass;
    pass->SetInputDataObject(local);
    pass->GetArraySelection(association)->EnableArray(name.c_str());
    vtkNew<vtkResampleToImage> resample;
    resample->SetInputConnection(pass->GetOutputPort());
    resample->SetUseInputBounds(false);
    resample->SetSamplingBounds(bounds);
    resample->SetSamplingDimensions(dims);
    resample->Update();
    vtkImageData* out = resample->GetOutput();
    values = out ? out->GetPointData()->GetArray(name.c_str()) : nullptr;
    mask = out ? out->GetPointData()->GetArray(resample->GetMaskArrayName()) : nullptr;
  }
  const int64_t count = Count(box);
  if (values && values->GetDataType() == VTK_DOUBLE)
    field = vtkSmartPointer<vtkDoubleArray>::New();
  else
    field = vtkSmartPointer<vtkFloatArray>::New();
  field->SetName(name.c_str());
  field->SetNumberOfComponents(this->Components);
  field->SetNumberOfTuples(count);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const bool ok = values && mask && values->GetNumberOfTuples() == count && mask->GetNumberOfTuples() == count &&
    values->GetNumberOfComponents() == this->Components;
  if (!ok)
    problem = "resampling this rank's cells gave no '" + name + "' values";
  for (vtkIdType i = 0; i < count; ++i)
  {
    const bool in = ok && mask->GetComponent(i, 0) != 0.0;
    for (int q = 0; q < this->Components; ++q)
      field->SetComponent(i, q, in ? values->GetComponent(i, q) : nan);
  }
  image->GetPointData()->AddArray(field);
  this->ResampledImage = image;
  return ok;
}

void DataSetPiece::Exchange()
{
  vtkMultiProcessController* c = DistributedController();
  const int me = c->GetLocalProcessId(), n = c->GetNumberOfProcesses();
  vtkDataArray* mine =
    this->ResampledImage ? this->ResampledImage->GetPointData()->GetArray(0) : nullptr;
  const int nc = this->Components;
  this->Filled = 0;
  auto send = [&](int to) {
    const Box part = Intersect(this->ResampledBoxes[size_t(me)], this->PaddedBoxes[size_t(to)]);
    if (Empty(part) || !mine)
      return;
    std::vector<double> buffer(size_t(Count(part) * nc));
    size_t at = 0;
    const Box& ext = this->ResampledBoxes[size_t(me)];
    for (int k = part[4]; k <= part[5]; ++k)
      for (int j = part[2]; j <= part[3]; ++j)
        for (int i = part[0]; i <= part[1]; ++i)
          for (int q = 0; q < nc; ++q)
            buffer[at++] = mine->GetComponent(IndexIn(ext, i, j, k), q);
    c->Send(buffer.data(), vtkIdType(buffer.size()), to, kExchangeTag);
  };
  auto receive = [&](int from) {
    const Box part = Intersect(this->ResampledBoxes[size_t(from)], this->PaddedBoxes[size_t(me)]);
    if (Empty(part) || Empty(this->ResampledBoxes[size_t(me)]))
      return;
    std::vector<double> buffer(size_t(Count(part) * nc));
    c->Receive(buffer.data(), vtkIdType(buffer.size()), from, kExchangeTag);
    if (!mine)
      return;
    size_t at = 0;
    const Box& ext = this->ResampledBoxes[size_t(me)];
    for (int k = part[4]; k <= part[5]; ++k)
      for (int j = part[2]; j <= part[3]; ++j)
        for (int i = part[0]; i <= part[1]; ++i, at += size_t(nc))
        {
          const vtkIdType index = IndexIn(ext, i, j, k);
          if (!std::isnan(mine->GetComponent(index, 0)) || std::isnan(buffer[at]))
            continue;
          for (int q = 0; q < nc; ++q)
            mine->SetComponent(index, q, buffer[at + size_t(q)]);
          ++this->Filled;
        }
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
}

void DataSetPiece::CropToPadded()
{
  vtkMultiProcessController* c = DistributedController();
  const size_t me = size_t(c->GetLocalProcessId());
  this->TrainingImage = nullptr;
  this->OutsideMask = nullptr;
  Box padded = this->PaddedBoxes[me];
  if (Empty(padded) || !this->ResampledImage)
    return;
  vtkDataArray* from = this->ResampledImage->GetPointData()->GetArray(0);
  vtkSmartPointer<vtkDataArray> to;
  to.TakeReference(from->NewInstance());
  to->SetName(from->GetName());
  to->SetNumberOfComponents(from->GetNumberOfComponents());
  to->SetNumberOfTuples(Count(padded));
  auto outside = std::make_shared<std::vector<uint8_t>>(size_t(Count(padded)), uint8_t(0));
  vtkIdType at = 0;
  for (int k = padded[4]; k <= padded[5]; ++k)
    for (int j = padded[2]; j <= padded[3]; ++j)
      for (int i = padded[0]; i <= padded[1]; ++i, ++at)
      {
        const vtkIdType index = IndexIn(this->ResampledBoxes[me], i, j, k);
        to->SetTuple(at, index, from);
        (*outside)[size_t(at)] = std::isnan(from->GetComponent(index, 0)) ? 1 : 0;
      }
  this->TrainingImage = vtkSmartPointer<vtkImageData>::New();
  this->TrainingImage->SetExtent(padded.data());
  this->TrainingImage->SetOrigin(this->Origin);
  this->TrainingImage->SetSpacing(this->Spacing);
  this->TrainingImage->GetPointData()->AddArray(to);
  this->OutsideMask = outside;
  this->ResampledImage = nullptr;
}

//------------------------------------------------------------------------------
bool DataSetPiece::Resolve(vtkDataSet* local, const std::string& name, int association, const int requested[3],
  int dims[3], std::string& problem)
{
  vtkMultiProcessController* c = DistributedController();
  const Summary mine = this->LocalSummary(local, name, association);
  std::vector<Summary> all(size_t(c->GetNumberOfProcesses()));
  c->AllGather(mine.data(), all.front().data(), vtkIdType(mine.size()));
  if (!this->Lattice(all, name, requested, problem))
    return false;
  std::copy(this->Dims, this->Dims + 3, dims);
  return true;
}

bool DataSetPiece::Prepare(vtkDataSet* local, const std::string& name, int association, const int requested[3],
  std::string& problem)
{
  vtkMultiProcessController* c = DistributedController();
  const Summary mine = this->LocalSummary(local, name, association);
  std::vector<Summary> all(size_t(c->GetNumberOfProcesses()));
  c->AllGather(mine.data(), all.front().data(), vtkIdType(mine.size()));
  // A new piece when any rank's input, the array or the dimensions changed (the same decision on every rank).
  uint64_t stamp = this->SummaryStamp;
  for (int a = 0; a < 3; ++a)
    stamp = stamp * 1099511628211ull ^ uint64_t(requested[a] + 1);
  int changed = !this->Prepared || stamp != this->PreparedStamp ? 1 : 0, anyChanged = 0;
  c->AllReduce(&changed, &anyChanged, 1, vtkCommunicator::MAX_OP);
  if (!anyChanged)
    return true;
  this->Prepared = false;
  this->TrainingImage = nullptr;
  this->OutsideMask = nullptr;
  if (!this->Lattice(all, name, requested, problem)) // the same on every rank: no collective follows
    return false;
  this->Regions(all);
  this->OwnedExtent = this->OwnedBoxes[size_t(c->GetLocalProcessId())];
  std::string ownProblem;
  int failed = this->Resample(local, name, association, ownProblem) ? 0 : 1, anyFailed = 0;
  this->Exchange();
  this->CropToPadded();
  c->AllReduce(&failed, &anyFailed, 1, vtkCommunicator::MAX_OP);
  if (anyFailed)
  {
    problem = failed ? ownProblem : "another rank could not resample its cells";
    this->TrainingImage = nullptr;
    return false;
  }
  this->OwnBytes = mine[kBytes];
  this->OwnSamples = mine[kSamples];
  std::ostringstream d;
  const int* e = this->OwnedExtent.data();
  d << (local ? local->GetClassName() : "no") << " piece, " << int64_t(mine[kSamples])
    << (association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? " cells" : " points") << " of its own, resampled on "
    << this->Dims[0] << " x " << this->Dims[1] << " x " << this->Dims[2] << " (owns " << e[0] << ".." << e[1] << ", "
    << e[2] << ".." << e[3] << ", " << e[4] << ".." << e[5] << "; " << this->Filled
    << " samples from neighbouring ranks; "
    << (this->OutsideMask ? std::count(this->OutsideMask->begin(), this->OutsideMask->end(), uint8_t(1)) : 0)
    << " outside the domain)";
  this->Text = d.str();
  this->Prepared = true;
  this->PreparedStamp = stamp;
  return true;
}

} // namespace vtkNeuralCompressInternals
