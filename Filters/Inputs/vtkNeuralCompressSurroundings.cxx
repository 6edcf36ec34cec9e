// The coarse grid of the whole field for shadows and path tracing across pieces (vtkNeuralCompressSurroundings.h).
#include "vtkNeuralCompressSurroundings.h"

#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralNetworkArray.h"

#include "Core/DomainMask.h"
#include "Core/NetworkSession.h"
#include "Core/ValueRange.h"

#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkIntArray.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <exception>

namespace vtkNeuralCompressInternals
{

namespace
{
/// Points decoded per inference call.
constexpr int64_t kDecodeChunk = 1 << 16;

uint64_t Mix(uint64_t hash, uint64_t value)
{
  return (hash ^ value) * 1099511628211ull;
}

/// This rank's piece bounds (NeuralPieceBounds) and network session; false when it has none (an empty or failed
/// output, or a network whose session cannot be made: `problem` says why).
bool OwnPiece(vtkImageData* output, double own[6], std::shared_ptr<nv::NetworkSession>& session,
  std::string& problem)
{
  vtkFieldData* fd = output && output->GetNumberOfPoints() > 0 ? output->GetFieldData() : nullptr;
  vtkDataArray* piece = fd ? vtkDataArray::SafeDownCast(fd->GetAbstractArray("NeuralPieceBounds")) : nullptr;
  if (!piece || piece->GetNumberOfValues() != 6 || !vtkNeuralNetworkArray::Find(fd))
    return false;
  for (int k = 0; k < 6; ++k)
    own[k] = piece->GetComponent(k, 0);
  for (int a = 0; a < 3; ++a)
    if (!(std::isfinite(own[2 * a]) && std::isfinite(own[2 * a + 1]) && own[2 * a] <= own[2 * a + 1]))
      return false;
  try
  {
    session = vtkNeuralNetworkArray::Session(fd);
  }
  catch (const std::exception& e)
  {
    problem = std::string("this rank's network cannot be evaluated for the surroundings grid: ") + e.what();
    return false;
  }
  return session != nullptr;
}
} // namespace

void SurroundingsDimensions(const double bounds[6], int64_t budget, int dims[3])
{
  double length[3], volume = 1.0;
  int spanning = 0;
  for (int a = 0; a < 3; ++a)
  {
    length[a] = std::max(0.0, bounds[2 * a + 1] - bounds[2 * a]);
    if (length[a] > 0.0)
    {
      volume *= length[a];
      ++spanning;
    }
  }
  // Equal spacing h on the spanning axes: (length / h)^spanning = budget.
  const double h = spanning > 0 ? std::pow(volume / static_cast<double>(budget), 1.0 / spanning) : 1.0;
  for (int a = 0; a < 3; ++a)
    dims[a] = length[a] > 0.0 && h > 0.0
      ? static_cast<int>(std::max(2.0, std::min(4096.0, std::round(length[a] / h) + 1.0)))
      : 2;
}

void OwnedLatticeRange(double wholeLo, double wholeHi, int n, double pieceLo, double pieceHi, int& lo, int& hi)
{
  if (!(wholeHi > wholeLo) || n < 2)
  {
    lo = 0; // a flat axis is never split: every piece has all of it
    hi = n - 1;
    return;
  }
  const double h = (wholeHi - wholeLo) / static_cast<double>(n - 1);
  // The same expression for a piece's upper plane and its neighbour's lower one: the two agree on who owns a point.
  auto firstAtOrAbove = [&](double x) {
    return static_cast<int>(std::max(0.0, std::min(static_cast<double>(n), std::ceil((x - wholeLo) / h - 1e-9))));
  };
  lo = firstAtOrAbove(pieceLo);
  hi = (pieceHi >= wholeHi ? n : firstAtOrAbove(pieceHi)) - 1;
}

bool Surroundings::WholeBounds(const double* own, double whole[6])
{
  // Minima of (lo, -hi) per axis over the ranks with a piece.
  double mine[6], all[6];
  for (int a = 0; a < 3; ++a)
  {
    mine[2 * a] = own ? own[2 * a] : DBL_MAX;
    mine[2 * a + 1] = own ? -own[2 * a + 1] : DBL_MAX;
  }
  std::copy(mine, mine + 6, all);
  DistributedController()->AllReduce(mine, all, 6, vtkCommunicator::MIN_OP);
  for (int a = 0; a < 3; ++a)
  {
    whole[2 * a] = all[2 * a];
    whole[2 * a + 1] = -all[2 * a + 1];
    if (!(whole[2 * a] <= whole[2 * a + 1]))
      return false;
  }
  return true;
}

void Surroundings::DecodeOwnPoints(nv::NetworkSession& session, const double whole[6], const int dims[3],
  const double own[6], std::vector<float>& values)
{
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a)
  {
    OwnedLatticeRange(whole[2 * a], whole[2 * a + 1], dims[a], own[2 * a], own[2 * a + 1], lo[a], hi[a]);
    if (lo[a] > hi[a])
      return;
  }
  const nv::SourceInfo& src = session.model().source;
  const nv::ValueRange range(src.valueMin, src.valueMax);
  const bool masked = !src.domain.empty();
  const int domainDims[3] = { static_cast<int>(src.dims[0]), static_cast<int>(src.dims[1]),
    static_cast<int>(src.dims[2]) };
  // Lattice point i along axis a -> this network's coordinates (its source bounds map to [0,1]^3).
  auto unit = [&](int a, int i) {
    const double x = dims[a] > 1 ? whole[2 * a] + (whole[2 * a + 1] - whole[2 * a]) * i / (dims[a] - 1) : whole[2 * a];
    const double b0 = src.bounds[2 * a], b1 = src.bounds[2 * a + 1];
    const double u = b1 > b0 ? (x - b0) / (b1 - b0) : 0.5;
    return static_cast<float>(std::min(1.0, std::max(0.0, u)));
  };
  std::vector<int64_t> index;
  std::vector<float> xyz, out;
  auto flush = [&]() {
    out.resize(index.size());
    session.inferPoints(xyz.data(), static_cast<int64_t>(index.size()), out.data(), nv::Memory::Host);
    for (size_t k = 0; k < index.size(); ++k)
    {
      const double v = range.denormalize(static_cast<double>(out[k]));
      const bool inside = !masked || nv::domainBit(src.domain.data(), domainDims, xyz[3 * k], xyz[3 * k + 1],
        xyz[3 * k + 2]);
      if (inside && std::isfinite(v) && std::fabs(v) < FLT_MAX)
        values[index[k]] = static_cast<float>(v);
    }
    index.clear();
    xyz.clear();
  };
  for (int z = lo[2]; z <= hi[2]; ++z)
    for (int y = lo[1]; y <= hi[1]; ++y)
      for (int x = lo[0]; x <= hi[0]; ++x)
      {
        index.push_back((static_cast<int64_t>(z) * dims[1] + y) * dims[0] + x);
        xyz.insert(xyz.end(), { unit(0, x), unit(1, y), unit(2, z) });
        if (static_cast<int64_t>(index.size()) >= kDecodeChunk)
          flush();
      }
  if (!index.empty())
    flush();
}

void Surroundings::Keep(const double whole[6], const int dims[3], vtkFloatArray* values)
{
  // The reduced maxima: a point no rank had a value for is still kNoValue (NaN there: no data).
  float* v = values->GetPointer(0);
  for (vtkIdType i = 0; i < values->GetNumberOfValues(); ++i)
    if (v[i] == kNoValue)
      v[i] = NAN;
  values->SetName("NeuralSurroundings");
  this->Values = values;
  this->Dimensions = vtkSmartPointer<vtkIntArray>::New();
  this->Dimensions->SetName("NeuralSurroundingsDimensions");
  this->BoundsArray = vtkSmartPointer<vtkDoubleArray>::New();
  this->BoundsArray->SetName("NeuralSurroundingsBounds");
  for (int a = 0; a < 3; ++a)
  {
    this->Dims[a] = dims[a];
    this->Dimensions->InsertNextValue(dims[a]);
  }
  for (int k = 0; k < 6; ++k)
  {
    this->Bounds[k] = whole[k];
    this->BoundsArray->InsertNextValue(whole[k]);
  }
}

void Surroundings::Update(vtkImageData* output, std::string& problem)
{
  vtkMultiProcessController* c = DistributedController();
  if (!c)
    return;
  double own[6], whole[6];
  std::shared_ptr<nv::NetworkSession> session;
  const bool have = OwnPiece(output, own, session, problem);
  if (!WholeBounds(have ? own : nullptr, whole))
    return; // no rank has a piece (the same answer on every rank)
  int dims[3];
  SurroundingsDimensions(whole, kSurroundingsSamples, dims);
  // Built again when some rank's network (a new version while it trains) or piece changed.
  uint64_t signature = 1469598103934665603ull;
  if (have)
  {
    signature = Mix(Mix(signature, reinterpret_cast<uintptr_t>(session.get())), session->version());
    for (double b : own)
      signature = Mix(signature, static_cast<uint64_t>(std::llround(b * 1e6)));
  }
  int changed = signature != this->Signature || !std::equal(dims, dims + 3, this->Dims) ||
      !std::equal(whole, whole + 6, this->Bounds) ? 1 : 0;
  int anyChanged = changed;
  c->AllReduce(&changed, &anyChanged, 1, vtkCommunicator::MAX_OP);
  this->Signature = signature;
  if (anyChanged)
  {
    // One float a point: this rank's value where it owns the point, kNoValue elsewhere; the maximum over the ranks
    // is the owner's (each point has one owner). Reduced straight into the array kept (a 80^3 grid: 2 MiB, and as
    // much while it is reduced).
    const int64_t n = static_cast<int64_t>(dims[0]) * dims[1] * dims[2];
    std::vector<float> mine(static_cast<size_t>(n), kNoValue);
    vtkNew<vtkFloatArray> all;
    all->SetNumberOfValues(n);
    try
    {
      if (have)
        DecodeOwnPoints(*session, whole, dims, own, mine);
    }
    catch (const std::exception& e)
    {
      // This rank contributes nothing (its points have no value); the collective goes on.
      std::fill(mine.begin(), mine.end(), kNoValue);
      problem = std::string("decoding this rank's network for the surroundings grid failed: ") + e.what();
    }
    c->AllReduce(mine.data(), all->GetPointer(0), static_cast<vtkIdType>(n), vtkCommunicator::MAX_OP);
    this->Keep(whole, dims, all);
  }
  if (have && this->Values)
  {
    vtkFieldData* fd = output->GetFieldData();
    fd->AddArray(this->Values);
    fd->AddArray(this->Dimensions);
    fd->AddArray(this->BoundsArray);
  }
}

} // namespace vtkNeuralCompressInternals
