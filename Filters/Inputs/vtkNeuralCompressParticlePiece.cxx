// A rank's piece of a particle set under MPI (vtkNeuralCompressParticlePiece.h).
#include "vtkNeuralCompressParticlePiece.h"

#include "vtkNeuralCompressDataSetPiece.h"
#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressPartition.h"
#include "vtkNeuralCompressResample.h"

#include "vtkDataArray.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkMultiProcessController.h"
#include "vtkPointData.h"
#include "vtkPointSet.h"

#include "Core/Error.h"
#include "Particles/ParticleField.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>

namespace vtkNeuralCompressInternals
{
namespace
{
using Box = std::array<int, 6>;

/// The tags of the pairwise exchanges: occupied spacing cells, kernel sums.
constexpr int kOccupancyTag = 0x4E56504F; // "NVPO"
constexpr int kSumsTag = 0x4E565053;      // "NVPS"

// The summary's layout (ParticlePiece::Summary).
enum SummaryField
{
  kHolds = 0,        ///< 1: the rank holds particles the reconstruction uses
  kHasArray = 1,     ///< 1: the array is there (or the rank holds no points)
  kFiniteBounds = 2, ///< 6: the box of the positions that are finite (the lattice's dimensions)
  kFinite = 8,       ///< their count
  kUsedBounds = 9,   ///< 6: the box of the particles used (the lattice's origin and spacing)
  kUsed = 15,        ///< their count
  kBytes = 16,       ///< the particles' bytes (positions and the scalar)
  kMaxRadius = 17,   ///< the largest radius of the radius array among those used (0: no array)
  kFailed = 18       ///< 1: the rank could not read its particles (a missing radius array)
};

bool Empty(const Box& b)
{
  return b[0] > b[1] || b[2] > b[3] || b[4] > b[5];
}

Box Intersect(const Box& a, const Box& b)
{
  Box o;
  for (int i = 0; i < 3; ++i)
  {
    o[size_t(2 * i)] = std::max(a[size_t(2 * i)], b[size_t(2 * i)]);
    o[size_t(2 * i + 1)] = std::min(a[size_t(2 * i + 1)], b[size_t(2 * i + 1)]);
  }
  return o;
}

int64_t Count(const Box& b)
{
  return Empty(b) ? 0 : int64_t(b[1] - b[0] + 1) * (b[3] - b[2] + 1) * (b[5] - b[4] + 1);
}

int64_t IndexIn(const Box& ext, int i, int j, int k)
{
  return (int64_t(k - ext[4]) * (ext[3] - ext[2] + 1) + (j - ext[2])) * (ext[1] - ext[0] + 1) + (i - ext[0]);
}

/// The engine's rule (nv::ParticleField): a particle is used when its position and value are finite and its radius
/// (from an array) finite and positive.
bool IsUsed(const ParticleArrays& p, size_t i)
{
  const double* x = &p.Xyz[3 * i];
  if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]) || !std::isfinite(p.Values[i]))
    return false;
  return p.Radii.empty() || (p.Radii[i] > 0.0 && std::isfinite(p.Radii[i]));
}

void Widen(double* bounds, const double x[3], bool first)
{
  for (int a = 0; a < 3; ++a)
  {
    bounds[2 * a] = first ? x[a] : std::min(bounds[2 * a], x[a]);
    bounds[2 * a + 1] = first ? x[a] : std::max(bounds[2 * a + 1], x[a]);
  }
}

/// Calls visit(a, b) for every pair of ranks a < b in the same order on every rank (a blocking send of the lower
/// rank first): no cycle of waiting sends.
template <class Visit>
void ForEachPair(int ranks, Visit&& visit)
{
  for (int a = 0; a < ranks; ++a)
    for (int b = a + 1; b < ranks; ++b)
      visit(a, b);
}

/// The cells of a grid that some rank occupies, every rank's `occupied` flags over its own box of cells (`boxes`,
/// known to every rank) counted once: a rank tells each higher rank whose box overlaps its own which shared cells it
/// holds, and a cell counts for the lowest rank that holds it. A collective (one all-reduce).
double CountOccupiedCells(const std::vector<Box>& boxes, const std::vector<unsigned char>& occupied)
{
  vtkMultiProcessController* c = DistributedController();
  const int me = c->GetLocalProcessId();
  const Box& own = boxes[size_t(me)];
  std::vector<unsigned char> taken(occupied.size(), 0);
  ForEachPair(c->GetNumberOfProcesses(), [&](int a, int b) {
    const Box shared = Intersect(boxes[size_t(a)], boxes[size_t(b)]);
    if (Empty(shared) || (me != a && me != b))
      return;
    std::vector<unsigned char> buffer(size_t(Count(shared)));
    size_t at = 0;
    for (int k = shared[4]; k <= shared[5]; ++k)
      for (int j = shared[2]; j <= shared[3]; ++j)
        for (int i = shared[0]; i <= shared[1]; ++i, ++at)
          if (me == a)
            buffer[at] = occupied[size_t(IndexIn(own, i, j, k))];
    if (me == a)
    {
      c->Send(buffer.data(), vtkIdType(buffer.size()), b, kOccupancyTag);
      return;
    }
    c->Receive(buffer.data(), vtkIdType(buffer.size()), a, kOccupancyTag);
    at = 0;
    for (int k = shared[4]; k <= shared[5]; ++k)
      for (int j = shared[2]; j <= shared[3]; ++j)
        for (int i = shared[0]; i <= shared[1]; ++i, ++at)
          taken[size_t(IndexIn(own, i, j, k))] |= buffer[at];
  });
  double mine = 0.0, total = 0.0;
  for (size_t i = 0; i < occupied.size(); ++i)
    mine += occupied[i] && !taken[i] ? 1.0 : 0.0;
  c->AllReduce(&mine, &total, 1, vtkCommunicator::SUM_OP);
  return total;
}
} // namespace

//------------------------------------------------------------------------------
bool PerRankParticles(vtkDataObject* local)
{
  vtkMultiProcessController* c = DistributedController();
  if (!c)
    return false;
  auto* points = vtkPointSet::SafeDownCast(local);
  const bool particles = points && IsParticleSet(points);
  int mine[2] = { points && (particles || points->GetNumberOfPoints() == 0) ? 1 : 0, particles ? 0 : 1 }, all[2];
  c->AllReduce(mine, all, 2, vtkCommunicator::MIN_OP); // every rank a particle set or empty; one at least not empty
  return all[0] != 0 && all[1] == 0;
}

ParticlePiece::ParticlePiece() = default;
ParticlePiece::~ParticlePiece() = default;

//------------------------------------------------------------------------------
bool ParticlePiece::Summarize(vtkDataObject* local, const std::string& name, const ParticleSettings& settings,
  std::vector<Summary>& all, std::string& problem)
{
  uint64_t stamp = InputStamp(local, name, vtkDataObject::FIELD_ASSOCIATION_POINTS);
  for (uint64_t v : { uint64_t(std::hash<std::string>()(settings.RadiusArray)), uint64_t(settings.VectorMode + 7),
         uint64_t(settings.VectorComponent + 11) })
    stamp = stamp * 1099511628211ull ^ v;
  if (!this->ArraysValid || stamp != this->SummaryStamp)
  {
    Summary s{};
    s[kHasArray] = 1.0;
    std::string ownProblem;
    this->Arrays = ParticleArrays();
    if (local && !CollectParticles(local, name, settings, this->Arrays, ownProblem))
      s[kFailed] = 1.0;
    const ParticleArrays& p = this->Arrays;
    for (size_t i = 0; i < p.Values.size(); ++i)
    {
      const double* x = &p.Xyz[3 * i];
      if (std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]))
        Widen(&s[kFiniteBounds], x, s[kFinite]++ == 0.0);
      if (!IsUsed(p, i))
        continue;
      Widen(&s[kUsedBounds], x, s[kUsed]++ == 0.0);
      s[kMaxRadius] = p.Radii.empty() ? 0.0 : std::max(s[kMaxRadius], p.Radii[i]);
    }
    auto* points = vtkPointSet::SafeDownCast(local);
    s[kHasArray] = !points || points->GetNumberOfPoints() == 0 || points->GetPointData()->GetArray(name.c_str());
    s[kHolds] = s[kUsed] > 0.0 ? 1.0 : 0.0;
    s[kBytes] = double(p.SourceBytes);
    this->Mine = s;
    this->SummaryStamp = stamp;
    this->ArraysValid = true;
    if (s[kFailed] != 0.0)
      problem = ownProblem;
  }
  vtkMultiProcessController* c = DistributedController();
  all.assign(size_t(c->GetNumberOfProcesses()), Summary{});
  c->AllGather(this->Mine.data(), all.front().data(), vtkIdType(this->Mine.size()));
  return true;
}

bool ParticlePiece::Lattice(const std::vector<Summary>& all, const int requested[3], std::string& problem)
{
  double finite[6], used[6];
  double finiteCount = 0.0, usedCount = 0.0;
  for (size_t r = 0; r < all.size(); ++r)
  {
    const Summary& s = all[r];
    if (s[kFailed] != 0.0 || s[kHasArray] == 0.0)
    {
      if (problem.empty())
        problem = "rank " + std::to_string(r) +
          (s[kFailed] != 0.0 ? " has no point array of particle radii (ParticleRadiusArray)"
                             : " holds particles without the point array");
      return false;
    }
    for (int a = 0; a < 6 && s[kFinite] > 0.0; ++a)
      finite[a] = finiteCount == 0.0 ? s[size_t(kFiniteBounds + a)]
        : a % 2                      ? std::max(finite[a], s[size_t(kFiniteBounds + a)])
                                     : std::min(finite[a], s[size_t(kFiniteBounds + a)]);
    for (int a = 0; a < 6 && s[kUsed] > 0.0; ++a)
      used[a] = usedCount == 0.0 ? s[size_t(kUsedBounds + a)]
        : a % 2                  ? std::max(used[a], s[size_t(kUsedBounds + a)])
                                 : std::min(used[a], s[size_t(kUsedBounds + a)]);
    finiteCount += s[kFinite];
    usedCount += s[kUsed];
  }
  if (finiteCount == 0.0 || usedCount == 0.0)
  {
    problem = finiteCount == 0.0 ? "no particle has a finite position"
                                 : "no particle can be used (non-finite values or radii that are not positive)";
    return false;
  }
  if (finite[1] == finite[0] && finite[3] == finite[2] && finite[5] == finite[4])
  {
    problem = "all particles lie at one point: no volume to sample";
    return false;
  }
  std::copy(requested, requested + 3, this->Dims);
  if (this->Dims[0] <= 0 || this->Dims[1] <= 0 || this->Dims[2] <= 0) // the serial automatic dimensions
    AutoSamplingDimensions(finite, std::max<int64_t>(1, int64_t(finiteCount) * 8 / 27), 0.0, this->Dims);
  if (double(this->Dims[0]) * this->Dims[1] * this->Dims[2] > 1024.0 * 1024.0 * 1024.0)
  {
    problem = "SamplingDimensions exceed 2^30 samples; choose at most 1024^3";
    return false;
  }
  for (int a = 0; a < 3; ++a)
  {
    // The serial image (InputResampler::ResampleParticles): the box of the particles used.
    this->Origin[a] = used[2 * a];
    this->Spacing[a] = this->Dims[a] > 1 && used[2 * a + 1] > used[2 * a]
      ? (used[2 * a + 1] - used[2 * a]) / (this->Dims[a] - 1)
      : 1.0;
    this->WholeExtent[size_t(2 * a)] = 0;
    this->WholeExtent[size_t(2 * a + 1)] = this->Dims[a] - 1;
  }
  return true;
}

double ParticlePiece::AutomaticRadius(const std::vector<Summary>& all)
{
  // The serial run's frame: the whole set's box of used particles, in units of its largest extent.
  double lo[3], hi[3], count = 0.0;
  for (const Summary& s : all)
    for (int a = 0; a < 3 && s[kUsed] > 0.0; ++a)
    {
      const double from = s[size_t(kUsedBounds + 2 * a)], to = s[size_t(kUsedBounds + 2 * a + 1)];
      lo[a] = count == 0.0 ? from : std::min(lo[a], from);
      hi[a] = count == 0.0 ? to : std::max(hi[a], to);
      count += a == 2 ? s[kUsed] : 0.0;
    }
  const double largest = std::max({ hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2] });
  if (!(largest > 0.0) || !std::isfinite(largest))
    return 0.0;
  const double scale = 1.0 / largest;
  const double extent[3] = { (hi[0] - lo[0]) * scale, (hi[1] - lo[1]) * scale, (hi[2] - lo[2]) * scale };
  const nv::SpacingGrid grid(int64_t(count), extent);
  auto cellOf = [&](const double x[3], int index[3]) {
    // As nv::ParticleField's records: float positions relative to the box, in its units.
    const float u[3] = { float((x[0] - lo[0]) * scale), float((x[1] - lo[1]) * scale),
      float((x[2] - lo[2]) * scale) };
    for (int a = 0; a < 3; ++a)
      index[a] = std::min(std::max(int(std::floor(double(u[a]) / grid.Edge)), 0), grid.Dims[a] - 1);
  };
  // A rank's box of the grid's cells: those of its particles' box (the cell of a position is monotonic in it).
  std::vector<Box> boxes(all.size(), Box{ { 0, -1, 0, -1, 0, -1 } });
  for (size_t r = 0; r < all.size(); ++r)
    for (int e = 0; e < 2 && all[r][kUsed] > 0.0; ++e)
    {
      const double corner[3] = { all[r][size_t(kUsedBounds + e)], all[r][size_t(kUsedBounds + 2 + e)],
        all[r][size_t(kUsedBounds + 4 + e)] };
      int index[3];
      cellOf(corner, index);
      for (int a = 0; a < 3; ++a)
        boxes[r][size_t(2 * a + e)] = index[a];
    }
  const Box& mine = boxes[size_t(DistributedController()->GetLocalProcessId())];
  std::vector<unsigned char> occupied(size_t(Count(mine)), 0);
  const ParticleArrays& p = this->Arrays;
  for (size_t i = 0; i < p.Values.size(); ++i)
  {
    int index[3];
    if (!IsUsed(p, i))
      continue;
    cellOf(&p.Xyz[3 * i], index);
    occupied[size_t(IndexIn(mine, index[0], index[1], index[2]))] = 1;
  }
  const double total = CountOccupiedCells(boxes, occupied);
  return nv::kAutoRadiusSpacings * grid.spacing(int64_t(total), int64_t(count)) / scale;
}

bool ParticlePiece::BuildField(const ParticleSettings& settings, std::string& problem)
{
  this->Field = nullptr;
  if (this->Mine[kUsed] <= 0.0)
    return true;
  nv::ParticleOptions options;
  options.Mode = static_cast<nv::ParticleFieldMode>(std::min(std::max(settings.Field, 0), 1));
  options.Kernel = static_cast<nv::ParticleKernel>(std::min(std::max(settings.Kernel, 0), 2));
  options.Radius = this->CommonRadius;
  const ParticleArrays& p = this->Arrays;
  try
  {
    const nv::ParticleInput input{ p.Xyz.data(), p.Values.data(), p.Radii.empty() ? nullptr : p.Radii.data(),
      int64_t(p.Values.size()) };
    this->Field = std::make_shared<const nv::ParticleField>(input, options);
  }
  catch (const nv::Error& e)
  {
    problem = e.what();
    return false;
  }
  this->Arrays = ParticleArrays(); // the locator holds the particles now
  this->ArraysValid = false;
  return true;
}

void ParticlePiece::Regions(const std::vector<Summary>& all)
{
  const Box none{ { 0, -1, 0, -1, 0, -1 } };
  std::vector<std::array<double, 6>> centres(all.size());
  std::vector<int> holders;
  for (size_t r = 0; r < all.size(); ++r)
  {
    std::copy(all[r].begin() + kUsedBounds, all[r].begin() + kUsedBounds + 6, centres[r].begin());
    if (all[r][kHolds] != 0.0)
      holders.push_back(int(r));
  }
  const std::vector<Box> owned = LatticeRegions(centres, holders, this->WholeExtent, this->Origin, this->Spacing);
  this->PaddedBoxes.assign(all.size(), none);
  this->ReachBoxes.assign(all.size(), none);
  for (size_t r = 0; r < all.size(); ++r)
  {
    if (all[r][kHolds] == 0.0)
      continue;
    const double radius = this->CommonRadius > 0.0 ? this->CommonRadius : all[r][kMaxRadius];
    Box padded = owned[r], reach;
    for (int a = 0; a < 3; ++a)
    {
      padded[size_t(2 * a)] -= kPieceGhostLayers;
      padded[size_t(2 * a + 1)] += kPieceGhostLayers;
      // The lattice points within the radius of the rank's particles' box, and one layer more (the locator rounds
      // positions to float).
      const double from = (all[r][size_t(kUsedBounds + 2 * a)] - radius - this->Origin[a]) / this->Spacing[a];
      const double to = (all[r][size_t(kUsedBounds + 2 * a + 1)] + radius - this->Origin[a]) / this->Spacing[a];
      reach[size_t(2 * a)] = int(std::max(-1.0, std::ceil(from) - 1.0));
      reach[size_t(2 * a + 1)] = int(std::min(double(this->Dims[a]), std::floor(to) + 1.0));
    }
    this->PaddedBoxes[r] = Empty(owned[r]) ? none : Intersect(padded, this->WholeExtent);
    this->ReachBoxes[r] = Intersect(reach, this->WholeExtent);
  }
  this->OwnedExtent = owned[size_t(DistributedController()->GetLocalProcessId())];
}

void ParticlePiece::AddKernelSums(std::vector<double>& weighted, std::vector<double>& weights)
{
  vtkMultiProcessController* c = DistributedController();
  const int me = c->GetLocalProcessId();
  const Box& padded = this->PaddedBoxes[size_t(me)];
  weighted.assign(size_t(Count(padded)), 0.0);
  weights.assign(weighted.size(), 0.0);
  this->FromNeighbours = 0;
  std::vector<double> xyz, buffer;
  // One z slice of `part` at a time: this rank's particles' sums at its lattice points (weighted, then weights).
  auto evaluate = [&](const Box& part, int k) {
    const int64_t n = int64_t(part[1] - part[0] + 1) * (part[3] - part[2] + 1);
    xyz.resize(size_t(3 * n));
    buffer.resize(size_t(2 * n));
    int64_t at = 0;
    for (int j = part[2]; j <= part[3]; ++j)
      for (int i = part[0]; i <= part[1]; ++i, ++at)
      {
        xyz[size_t(3 * at)] = this->Origin[0] + double(i) * this->Spacing[0];
        xyz[size_t(3 * at + 1)] = this->Origin[1] + double(j) * this->Spacing[1];
        xyz[size_t(3 * at + 2)] = this->Origin[2] + double(k) * this->Spacing[2];
      }
    this->Field->kernelSums(xyz.data(), n, buffer.data(), buffer.data() + n, 0);
  };
  auto add = [&](const Box& part, int k, bool neighbour) {
    const size_t n = buffer.size() / 2;
    size_t at = 0;
    for (int j = part[2]; j <= part[3]; ++j)
      for (int i = part[0]; i <= part[1]; ++i, ++at)
      {
        const size_t index = size_t(IndexIn(padded, i, j, k));
        weighted[index] += buffer[at];
        weights[index] += buffer[n + at];
        this->FromNeighbours += neighbour && buffer[n + at] > 0.0 ? 1 : 0;
      }
  };
  auto send = [&](int to) {
    const Box part = Intersect(this->ReachBoxes[size_t(me)], this->PaddedBoxes[size_t(to)]);
    for (int k = part[4]; !Empty(part) && k <= part[5]; ++k)
    {
      evaluate(part, k);
      c->Send(buffer.data(), vtkIdType(buffer.size()), to, kSumsTag);
    }
  };
  auto receive = [&](int from) {
    const Box part = Intersect(this->ReachBoxes[size_t(from)], padded);
    for (int k = part[4]; !Empty(part) && k <= part[5]; ++k)
    {
      buffer.resize(size_t(2 * int64_t(part[1] - part[0] + 1) * (part[3] - part[2] + 1)));
      c->Receive(buffer.data(), vtkIdType(buffer.size()), from, kSumsTag);
      add(part, k, true);
    }
  };
  const Box own = Intersect(this->ReachBoxes[size_t(me)], padded);
  for (int k = own[4]; !Empty(own) && k <= own[5]; ++k)
  {
    evaluate(own, k);
    add(own, k, false);
  }
  ForEachPair(c->GetNumberOfProcesses(), [&](int a, int b) {
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
  });
}

void ParticlePiece::MakeTrainingImage(
  const std::string& name, int mode, const std::vector<double>& weighted, const std::vector<double>& weights)
{
  Box padded = this->PaddedBoxes[size_t(DistributedController()->GetLocalProcessId())];
  this->TrainingImage = nullptr;
  this->OutsideMask = nullptr;
  if (Empty(padded))
    return;
  auto values = vtkSmartPointer<vtkFloatArray>::New();
  values->SetName(name.c_str());
  values->SetNumberOfTuples(vtkIdType(weights.size()));
  auto outside = std::make_shared<std::vector<uint8_t>>(weights.size(), uint8_t(0));
  const bool density = mode == int(nv::ParticleFieldMode::Density);
  for (size_t i = 0; i < weights.size(); ++i)
  {
    const bool inside = weights[i] > 0.0;
    (*outside)[i] = inside ? 0 : 1;
    values->SetValue(vtkIdType(i), !inside ? std::numeric_limits<float>::quiet_NaN()
                                           : float(density ? weighted[i] : weighted[i] / weights[i]));
  }
  this->TrainingImage = vtkSmartPointer<vtkImageData>::New();
  this->TrainingImage->SetExtent(padded.data());
  this->TrainingImage->SetOrigin(this->Origin);
  this->TrainingImage->SetSpacing(this->Spacing);
  this->TrainingImage->GetPointData()->AddArray(values);
  this->OutsideMask = outside;
}

std::array<double, 3> ParticlePiece::OwnedSums() const
{
  std::array<double, 3> sums{ { 0.0, 0.0, 0.0 } };
  vtkDataArray* values = this->TrainingImage ? this->TrainingImage->GetPointData()->GetArray(0) : nullptr;
  const Box& owned = this->OwnedExtent;
  Box padded;
  if (this->TrainingImage)
    this->TrainingImage->GetExtent(padded.data());
  for (int k = owned[4]; values && k <= owned[5]; ++k)
    for (int j = owned[2]; j <= owned[3]; ++j)
      for (int i = owned[0]; i <= owned[1]; ++i)
      {
        const double v = values->GetComponent(IndexIn(padded, i, j, k), 0);
        if (std::isnan(v))
          continue;
        sums[0] += 1.0;
        sums[1] += v;
        sums[2] += v * v;
      }
  return sums;
}

//------------------------------------------------------------------------------
bool ParticlePiece::Resolve(vtkDataObject* local, const std::string& name, int association, const int requested[3],
  const ParticleSettings& settings, int dims[3], std::string& problem)
{
  if (association != vtkDataObject::FIELD_ASSOCIATION_POINTS) // the same on every rank: no collective
  {
    problem = "a particle set's field is a point array; '" + name + "' is not one";
    return false;
  }
  std::vector<Summary> all;
  this->Summarize(local, name, settings, all, problem);
  if (!this->Lattice(all, requested, problem))
    return false;
  std::copy(this->Dims, this->Dims + 3, dims);
  return true;
}

bool ParticlePiece::Prepare(vtkDataObject* local, const std::string& name, int association, const int requested[3],
  const ParticleSettings& settings, std::string& problem)
{
  if (association != vtkDataObject::FIELD_ASSOCIATION_POINTS)
  {
    problem = "a particle set's field is a point array; '" + name + "' is not one";
    return false;
  }
  vtkMultiProcessController* c = DistributedController();
  std::vector<Summary> all;
  this->Summarize(local, name, settings, all, problem);
  uint64_t stamp = this->SummaryStamp;
  for (double v : { double(requested[0]), double(requested[1]), double(requested[2]), double(settings.Field),
         double(settings.Kernel), settings.Radius })
    stamp = stamp * 1099511628211ull ^ std::hash<double>()(v);
  int changed = !this->Prepared || stamp != this->PreparedStamp ? 1 : 0, anyChanged = 0;
  c->AllReduce(&changed, &anyChanged, 1, vtkCommunicator::MAX_OP);
  if (!anyChanged)
    return true;
  this->Prepared = false;
  this->TrainingImage = nullptr;
  this->OutsideMask = nullptr;
  if (!this->Lattice(all, requested, problem)) // the same on every rank: no collective follows
    return false;
  if (!this->ArraysValid && local) // released when the last field was built: read again (the summary stays)
    CollectParticles(local, name, settings, this->Arrays, problem);
  this->ArraysValid = true;
  this->CommonRadius = !settings.RadiusArray.empty() ? 0.0
    : settings.Radius > 0.0                          ? settings.Radius
                                                     : this->AutomaticRadius(all);
  std::string ownProblem;
  int failed = this->BuildField(settings, ownProblem) ? 0 : 1, anyFailed = 0;
  c->AllReduce(&failed, &anyFailed, 1, vtkCommunicator::MAX_OP);
  if (anyFailed)
  {
    problem = failed ? ownProblem : "another rank could not build its particles' locator";
    return false;
  }
  this->Regions(all);
  std::vector<double> weighted, weights;
  this->AddKernelSums(weighted, weights);
  this->MakeTrainingImage(name, settings.Field, weighted, weights);
  double inside[2] = { 0.0, 0.0 }, insideAll[2];
  for (size_t i = 0; i < weights.size(); ++i)
    inside[0] += weights[i] > 0.0 ? 1.0 : 0.0;
  inside[1] = double(weights.size());
  c->AllReduce(inside, insideAll, 2, vtkCommunicator::SUM_OP);
  if (insideAll[0] == 0.0)
  {
    problem = "no sample of the lattice lies within a particle's radius; raise ParticleRadius or SamplingDimensions";
    this->TrainingImage = nullptr;
    return false;
  }
  this->OwnBytes = this->Mine[kBytes];
  this->OwnParticles = this->Mine[kUsed];
  std::ostringstream d;
  d.precision(4);
  const int* e = this->OwnedExtent.data();
  d << "particle piece, " << int64_t(this->Mine[kUsed]) << " particles of its own ("
    << (this->Field ? this->Field->describe() : std::string("none")) << "); radius "
    << (settings.RadiusArray.empty() ? std::to_string(this->CommonRadius) : "from '" + settings.RadiusArray + "'")
    << (settings.RadiusArray.empty() && settings.Radius <= 0.0 ? " (automatic, the whole set's)" : "")
    << "; reconstructed on " << this->Dims[0] << " x " << this->Dims[1] << " x " << this->Dims[2] << " (owns "
    << e[0] << ".." << e[1] << ", " << e[2] << ".." << e[3] << ", " << e[4] << ".." << e[5] << "; kernel sums of "
    << this->FromNeighbours << " samples from neighbouring ranks; " << (weights.size() - size_t(inside[0]))
    << " outside the support)";
  this->Text = d.str();
  this->Prepared = true;
  this->PreparedStamp = stamp;
  return true;
}

} // namespace vtkNeuralCompressInternals
