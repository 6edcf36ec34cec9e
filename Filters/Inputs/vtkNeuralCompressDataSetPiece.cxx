// A rank's piece of a dataset or composite under MPI: its summary, the lattice and the regions
// (vtkNeuralCompressDataSetPiece.h; the resampling and exchange in vtkNeuralCompressPieceSampling.cxx).
#include "vtkNeuralCompressDataSetPiece.h"

#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressLatticeBox.h"
#include "vtkNeuralCompressParticles.h"
#include "vtkNeuralCompressPartition.h"
#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressSparse.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataSet.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataSetAttributes.h"
#include "vtkImageData.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace vtkNeuralCompressInternals
{
namespace
{
using Box = LatticeBox;

// The summary's layout (DataSetPiece::Summary).
enum SummaryField
{
  kHasCells = 0,    ///< 1: the rank holds cells of its own (not ghosts) in blocks that have the array
  kHasArray = 1,    ///< 1: some block of the rank has the array
  kBounds = 2,      ///< 6: the bounds of its blocks with the array (ghost cells included)
  kCentres = 8,     ///< 6: the box of their own cells' centres
  kSamples = 14,    ///< its own samples of the array (ghost points / cells and AMR cells under a finer level left out)
  kBytes = 15,      ///< their bytes
  kComponents = 16, ///< the array's components
  kFinest = 17,     ///< composites: the finest spacing of its image blocks with the array (0: none)
  kSurface = 18     ///< 1: a block with the array is poly data spread in 3D (a surface, no volume)
};

/// Poly data whose bounds are not flat in any axis: a surface, line or point set in 3D (no volume to sample).
bool SurfaceIn3D(vtkDataSet* leaf)
{
  if (!vtkPolyData::SafeDownCast(leaf))
    return false;
  double b[6];
  leaf->GetBounds(b);
  const double lx = b[1] - b[0], ly = b[3] - b[2], lz = b[5] - b[4];
  return std::min(lx, std::min(ly, lz)) > 1e-6 * std::max(lx, std::max(ly, lz));
}

/// A block's own cells (ghosts left out): the box of their centres grown in `lo`, `hi`; their count.
int64_t CellCentres(vtkDataSet* leaf, double lo[3], double hi[3])
{
  vtkUnsignedCharArray* cellGhosts = leaf->GetCellGhostArray();
  const unsigned char skip = vtkDataSetAttributes::DUPLICATECELL | vtkDataSetAttributes::HIDDENCELL;
  int64_t own = 0;
  const vtkIdType cells = leaf->GetNumberOfPoints() > 0 ? leaf->GetNumberOfCells() : 0;
  for (vtkIdType i = 0; i < cells; ++i)
  {
    if (cellGhosts && (cellGhosts->GetValue(i) & skip))
      continue;
    double b[6];
    leaf->GetCellBounds(i, b);
    for (int a = 0; a < 3; ++a)
    {
      const double centre = 0.5 * (b[2 * a] + b[2 * a + 1]);
      lo[a] = std::min(lo[a], centre);
      hi[a] = std::max(hi[a], centre);
    }
    ++own;
  }
  return own;
}

/// A block's own samples of `array` (ghosts and, for cells, AMR cells under a finer level left out).
int64_t CountOwnSamples(vtkDataSet* leaf, vtkDataArray* array, int association)
{
  const bool onCells = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  vtkUnsignedCharArray* ghosts = onCells ? leaf->GetCellGhostArray() : leaf->GetPointGhostArray();
  const unsigned char skip = onCells
    ? (vtkDataSetAttributes::DUPLICATECELL | vtkDataSetAttributes::HIDDENCELL | vtkDataSetAttributes::REFINEDCELL)
    : (vtkDataSetAttributes::DUPLICATEPOINT | vtkDataSetAttributes::HIDDENPOINT);
  int64_t samples = 0;
  for (vtkIdType i = 0; i < array->GetNumberOfTuples(); ++i)
    samples += ghosts && (ghosts->GetValue(i) & skip) ? 0 : 1;
  return samples;
}

/// The finest spacing of an image block with more than one point along an axis (0: not an image).
double ImageSpacing(vtkDataSet* leaf)
{
  auto* image = vtkImageData::SafeDownCast(leaf);
  double finest = 0.0;
  if (!image)
    return finest;
  const double* h = image->GetSpacing();
  int ext[6];
  image->GetExtent(ext);
  for (int a = 0; a < 3; ++a)
    if (ext[2 * a + 1] > ext[2 * a] && h[a] > 0.0)
      finest = finest > 0.0 ? std::min(finest, h[a]) : h[a];
  return finest;
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
vtkDataArray* PieceArray(vtkDataSet* block, const std::string& name, int association)
{
  return association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? block->GetCellData()->GetArray(name.c_str())
                                                                : block->GetPointData()->GetArray(name.c_str());
}

bool PerRankDataSetType(vtkDataObject* local)
{
  const bool dataset = vtkDataSet::SafeDownCast(local) && !vtkImageData::SafeDownCast(local);
  return (dataset || vtkCompositeDataSet::SafeDownCast(local)) && !IsSparseVoxels(local);
}

bool PerRankDataSets(vtkDataObject* local)
{
  vtkMultiProcessController* c = DistributedController();
  if (!c)
    return false;
  int mine = PerRankDataSetType(local) && !IsParticleSet(local) ? 1 : 0, all = 0;
  c->AllReduce(&mine, &all, 1, vtkCommunicator::MIN_OP);
  return all != 0;
}

//------------------------------------------------------------------------------
DataSetPiece::Summary DataSetPiece::LocalSummary(vtkDataObject* local, const std::string& name, int association)
{
  const uint64_t stamp = InputStamp(local, name, association) ^ (uint64_t(association) << 56);
  if (this->SummaryValid && stamp == this->SummaryStamp)
    return this->Mine;
  Summary s{};
  s[kComponents] = 1.0;
  const double inf = std::numeric_limits<double>::infinity();
  double lo[3] = { inf, inf, inf }, hi[3] = { -inf, -inf, -inf }, bounds[6] = { inf, -inf, inf, -inf, inf, -inf };
  const bool composite = vtkCompositeDataSet::SafeDownCast(local) != nullptr;
  int64_t own = 0;
  for (vtkDataSet* leaf : local ? InputLeaves(local) : std::vector<vtkDataSet*>())
  {
    vtkDataArray* array = leaf->GetNumberOfPoints() > 0 ? PieceArray(leaf, name, association) : nullptr;
    if (!array)
      continue;
    s[kHasArray] = 1.0;
    s[kComponents] = array->GetNumberOfComponents();
    s[kSurface] = SurfaceIn3D(leaf) ? 1.0 : s[kSurface];
    const int64_t cells = CellCentres(leaf, lo, hi);
    if (cells == 0)
      continue;
    own += cells;
    double b[6];
    leaf->GetBounds(b);
    for (int a = 0; a < 3; ++a)
    {
      bounds[2 * a] = std::min(bounds[2 * a], b[2 * a]);
      bounds[2 * a + 1] = std::max(bounds[2 * a + 1], b[2 * a + 1]);
    }
    const int64_t samples = CountOwnSamples(leaf, array, association);
    s[kSamples] += double(samples);
    s[kBytes] += double(samples) * array->GetNumberOfComponents() * std::max(1, array->GetDataTypeSize());
    const double spacing = composite ? ImageSpacing(leaf) : 0.0;
    if (spacing > 0.0)
      s[kFinest] = s[kFinest] > 0.0 ? std::min(s[kFinest], spacing) : spacing;
  }
  if (own > 0)
  {
    s[kHasCells] = 1.0;
    std::copy(bounds, bounds + 6, s.begin() + kBounds);
    for (int a = 0; a < 3; ++a)
    {
      s[size_t(kCentres + 2 * a)] = lo[a];
      s[size_t(kCentres + 2 * a + 1)] = hi[a];
    }
  }
  this->Mine = s;
  this->SummaryStamp = stamp;
  this->SummaryValid = true;
  return s;
}

bool DataSetPiece::Lattice(const std::vector<Summary>& all, const std::string& name, int association,
  const int requested[3], std::string& problem)
{
  double bounds[6] = { 0, -1, 0, -1, 0, -1 };
  double samples = 0.0, finest = 0.0;
  bool any = false, withArray = false;
  this->Components = 0;
  for (const Summary& s : all)
  {
    withArray |= s[kHasArray] != 0.0;
    if (s[kSurface] != 0.0)
    {
      problem = "poly data is a surface, line or point set in 3D and has no volume to sample; Neural Compress "
                "takes volumes (image, rectilinear, structured, unstructured grids, AMR) or planar poly data";
      return false;
    }
    if (s[kHasCells] == 0.0)
      continue;
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
    if (s[kFinest] > 0.0)
      finest = finest > 0.0 ? std::min(finest, s[kFinest]) : s[kFinest];
    any = true;
  }
  if (!withArray)
  {
    problem = "no block of the input has a " +
      std::string(association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? "cell" : "point") + " array '" + name + "'";
    return false;
  }
  if (!any)
  {
    problem = "no rank holds cells of the input";
    return false;
  }
  std::copy(requested, requested + 3, this->Dims);
  if (this->Dims[0] <= 0 || this->Dims[1] <= 0 || this->Dims[2] <= 0)
    AutoSamplingDimensions(bounds, static_cast<int64_t>(samples), finest, this->Dims);
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
  std::vector<int> holders;
  for (size_t r = 0; r < n; ++r)
    if (all[r][kHasCells] != 0.0)
      holders.push_back(static_cast<int>(r));
  SplitRegion(all, holders, this->WholeExtent, this->Origin, this->Spacing, this->OwnedBoxes);
  for (size_t r = 0; r < n; ++r)
    if (!IsEmptyBox(this->OwnedBoxes[r]))
      this->PaddedBoxes[r] = GrowBox(this->OwnedBoxes[r], kPieceGhostLayers, this->WholeExtent);
}

//------------------------------------------------------------------------------
bool DataSetPiece::Resolve(vtkDataObject* local, const std::string& name, int association, const int requested[3],
  int dims[3], std::string& problem)
{
  vtkMultiProcessController* c = DistributedController();
  const Summary mine = this->LocalSummary(local, name, association);
  std::vector<Summary> all(size_t(c->GetNumberOfProcesses()));
  c->AllGather(mine.data(), all.front().data(), vtkIdType(mine.size()));
  if (!this->Lattice(all, name, association, requested, problem))
    return false;
  std::copy(this->Dims, this->Dims + 3, dims);
  return true;
}

bool DataSetPiece::Prepare(vtkDataObject* local, const std::string& name, int association, const int requested[3],
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
  if (!this->Lattice(all, name, association, requested, problem)) // the same on every rank: no collective follows
    return false;
  this->Regions(all);
  this->OwnedExtent = this->OwnedBoxes[size_t(c->GetLocalProcessId())];
  std::string ownProblem;
  int failed = this->SampleRegions(local, name, association, ownProblem) ? 0 : 1, anyFailed = 0;
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
    << (association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? " cells" : " points") << " of its own in "
    << this->Blocks << (this->Blocks == 1 ? " block" : " blocks") << ", resampled on "
    << this->Dims[0] << " x " << this->Dims[1] << " x " << this->Dims[2] << " (owns " << e[0] << ".." << e[1] << ", "
    << e[2] << ".." << e[3] << ", " << e[4] << ".." << e[5] << "; " << this->Filled
    << " samples from other ranks' blocks; "
    << (this->OutsideMask ? std::count(this->OutsideMask->begin(), this->OutsideMask->end(), uint8_t(1)) : 0)
    << " outside the domain)";
  this->Text = d.str();
  this->Prepared = true;
  this->PreparedStamp = stamp;
  return true;
}

} // namespace vtkNeuralCompressInternals
