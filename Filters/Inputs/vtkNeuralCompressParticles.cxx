#include "vtkNeuralCompressParticles.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressResample.h"

#include "vtkCellArray.h"
#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include "Core/Error.h"
#include "Particles/ParticleField.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <thread>
#include <vector>

namespace vtkNeuralCompressInternals
{
namespace
{
bool IsParticleLeaf(vtkDataSet* leaf)
{
  if (auto* poly = vtkPolyData::SafeDownCast(leaf))
    return poly->GetNumberOfLines() == 0 && poly->GetNumberOfPolys() == 0 && poly->GetNumberOfStrips() == 0;
  if (auto* grid = vtkUnstructuredGrid::SafeDownCast(leaf))
  {
    vtkUnsignedCharArray* types = grid->GetCellTypesArray();
    const vtkIdType n = types ? types->GetNumberOfTuples() : 0;
    for (vtkIdType i = 0; i < n; ++i)
      if (types->GetValue(i) != VTK_VERTEX && types->GetValue(i) != VTK_POLY_VERTEX)
        return false;
    return true;
  }
  return false;
}

/// The box of the finite positions of the leaves with point array `name`; false when there is none.
bool FiniteBounds(const std::vector<vtkDataSet*>& leaves, const std::string& name, double bounds[6], int64_t& count)
{
  bool any = false;
  count = 0;
  for (vtkDataSet* leaf : leaves)
  {
    if (!leaf->GetPointData()->GetArray(name.c_str()))
      continue;
    for (vtkIdType i = 0; i < leaf->GetNumberOfPoints(); ++i)
    {
      double x[3];
      leaf->GetPoint(i, x);
      if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
        continue;
      for (int a = 0; a < 3; ++a)
      {
        bounds[2 * a] = any ? std::min(bounds[2 * a], x[a]) : x[a];
        bounds[2 * a + 1] = any ? std::max(bounds[2 * a + 1], x[a]) : x[a];
      }
      any = true;
      ++count;
    }
  }
  return any;
}

/// Calls work(first, last) on `count` items split between every core (one share when they are few).
template <class Work>
void ParallelRanges(int64_t count, Work&& work)
{
  const int cores = std::max(1, int(std::thread::hardware_concurrency()));
  const int n = int(std::min<int64_t>(cores, std::max<int64_t>(1, count / 65536)));
  std::vector<std::thread> pool;
  for (int t = 1; t < n; ++t)
    pool.emplace_back([&work, count, n, t] { work(count * t / n, count * (t + 1) / n); });
  work(0, count / n);
  for (std::thread& thread : pool)
    thread.join();
}
} // namespace

bool IsParticleSet(vtkDataObject* input)
{
  bool any = false;
  for (vtkDataSet* leaf : InputLeaves(input))
  {
    if (leaf->GetNumberOfPoints() == 0)
      continue;
    if (!IsParticleLeaf(leaf))
      return false;
    any = true;
  }
  return any;
}

bool ResolveParticleDimensions(vtkDataObject* input, const std::string& name, int association,
  const int requested[3], int dims[3], std::string& problem)
{
  if (association != vtkDataObject::FIELD_ASSOCIATION_POINTS)
  {
    problem = "a particle set's field is a point array; '" + name + "' is not one";
    return false;
  }
  const std::vector<vtkDataSet*> leaves = InputLeaves(input);
  double bounds[6];
  int64_t count = 0;
  if (!FiniteBounds(leaves, name, bounds, count))
  {
    problem = "no particle has a point array '" + name + "' and a finite position";
    return false;
  }
  if (bounds[1] == bounds[0] && bounds[3] == bounds[2] && bounds[5] == bounds[4])
  {
    std::ostringstream s;
    s << "all " << count << " particles lie at one point (" << bounds[0] << ", " << bounds[2] << ", " << bounds[4]
      << "): no volume to sample";
    problem = s.str();
    return false;
  }
  std::copy(requested, requested + 3, dims);
  if (dims[0] <= 0 || dims[1] <= 0 || dims[2] <= 0)
  {
    // About 8 samples per particle: the network's automatic finest level is twice the image's (measured on 200 k
    // particles after 300 steps: 35.8 dB at the particles; 2 per particle gave 33.8 dB).
    AutoSamplingDimensions(bounds, std::max<int64_t>(1, count * 8 / 27), 0.0, dims);
  }
  if (double(dims[0]) * dims[1] * dims[2] > 1024.0 * 1024.0 * 1024.0)
  {
    problem = "SamplingDimensions exceed 2^30 samples; choose at most 1024^3";
    return false;
  }
  return true;
}

bool CollectParticles(vtkDataObject* input, const std::string& name, const ParticleSettings& settings,
  ParticleArrays& arrays, std::string& problem)
{
  // Positions, values and radii as doubles (40 bytes a particle at most), allocated at once and filled by every core
  // (reading VTK arrays is thread-safe).
  arrays.SourceBytes = 0;
  const std::vector<vtkDataSet*> leaves = InputLeaves(input);
  int64_t total = 0, filled = 0;
  for (vtkDataSet* leaf : leaves)
    total += leaf->GetPointData()->GetArray(name.c_str()) ? int64_t(leaf->GetNumberOfPoints()) : 0;
  std::vector<double>& xyz = arrays.Xyz;
  std::vector<double>& values = arrays.Values;
  std::vector<double>& radii = arrays.Radii;
  xyz.assign(static_cast<size_t>(3 * total), 0.0);
  values.assign(static_cast<size_t>(total), 0.0);
  radii.assign(settings.RadiusArray.empty() ? 0 : static_cast<size_t>(total), 0.0);
  for (vtkDataSet* leaf : leaves)
  {
    vtkDataArray* array = leaf->GetPointData()->GetArray(name.c_str());
    if (!array || leaf->GetNumberOfPoints() == 0)
      continue;
    vtkDataArray* radius =
      settings.RadiusArray.empty() ? nullptr : leaf->GetPointData()->GetArray(settings.RadiusArray.c_str());
    if (!settings.RadiusArray.empty() && !radius)
    {
      problem = "no point array '" + settings.RadiusArray + "' of particle radii (ParticleRadiusArray)";
      return false;
    }
    auto* pointSet = vtkPointSet::SafeDownCast(leaf);
    vtkDataArray* positions = pointSet && pointSet->GetPoints() ? pointSet->GetPoints()->GetData() : nullptr;
    arrays.SourceBytes += (positions ? int64_t(positions->GetNumberOfValues()) * positions->GetDataTypeSize() : 0) +
      int64_t(array->GetNumberOfValues()) * std::max(1, array->GetDataTypeSize());
    const int64_t offset = filled;
    ParallelRanges(leaf->GetNumberOfPoints(), [&](int64_t first, int64_t last) {
      for (int64_t i = first; i < last; ++i)
      {
        leaf->GetPoint(vtkIdType(i), &xyz[size_t(3 * (offset + i))]);
        values[size_t(offset + i)] = TupleScalar(array, vtkIdType(i), settings.VectorMode, settings.VectorComponent);
        if (radius)
          radii[size_t(offset + i)] = radius->GetComponent(vtkIdType(i), 0);
      }
    });
    filled += leaf->GetNumberOfPoints();
  }
  return true;
}

std::shared_ptr<const nv::ParticleField> BuildParticleField(vtkDataObject* input, const std::string& name,
  const ParticleSettings& settings, int64_t& sourceBytes, std::string& problem)
{
  ParticleArrays arrays;
  sourceBytes = 0;
  if (!CollectParticles(input, name, settings, arrays, problem))
    return nullptr;
  sourceBytes = arrays.SourceBytes;
  const std::vector<double>& xyz = arrays.Xyz;
  const std::vector<double>& values = arrays.Values;
  const std::vector<double>& radii = arrays.Radii;
  nv::ParticleOptions options;
  options.Mode = static_cast<nv::ParticleFieldMode>(std::min(std::max(settings.Field, 0), 1));
  options.Kernel = static_cast<nv::ParticleKernel>(std::min(std::max(settings.Kernel, 0), 2));
  options.Radius = settings.Radius;
  try
  {
    const nv::ParticleInput particles{ xyz.data(), values.data(), radii.empty() ? nullptr : radii.data(),
      int64_t(values.size()) };
    return std::make_shared<const nv::ParticleField>(particles, options);
  }
  catch (const nv::Error& e)
  {
    problem = e.what();
    return nullptr;
  }
}

bool InputResampler::ResampleParticles(vtkDataObject* input, const std::string& name, int association,
  const int dimsIn[3], std::string& problem)
{
  int dims[3];
  if (!ResolveParticleDimensions(input, name, association, dimsIn, dims, problem))
    return false;
  const auto started = std::chrono::steady_clock::now();
  int64_t bytes = 0;
  std::shared_ptr<const nv::ParticleField> field = BuildParticleField(input, name, this->Particles, bytes, problem);
  if (!field)
    return false;
  // The evaluation per sample without the locator's setup: TimeBudget sizes the Probe bank from it, and the bank
  // reuses this locator (no setup to reserve).
  const auto built = std::chrono::steady_clock::now();
  this->Setup = 0.0;
  const double buildSeconds = std::chrono::duration<double>(built - started).count();
  const double* b = field->bounds();
  double spacing[3];
  for (int a = 0; a < 3; ++a)
    spacing[a] = dims[a] > 1 && b[2 * a + 1] > b[2 * a] ? (b[2 * a + 1] - b[2 * a]) / (dims[a] - 1) : 1.0;
  auto values = vtkSmartPointer<vtkFloatArray>::New();
  values->SetName(name.c_str());
  values->SetNumberOfTuples(vtkIdType(dims[0]) * dims[1] * dims[2]);
  // Slice by slice: the sample positions of one z slice at a time.
  const int64_t slice = int64_t(dims[0]) * dims[1];
  std::vector<double> xyz(static_cast<size_t>(3 * slice)), sliceValues(static_cast<size_t>(slice));
  int64_t inside = 0;
  for (int k = 0; k < dims[2]; ++k)
  {
    for (int64_t s = 0; s < slice; ++s)
    {
      const int64_t ij[2] = { s % dims[0], s / dims[0] };
      xyz[size_t(3 * s)] = b[0] + double(ij[0]) * spacing[0];
      xyz[size_t(3 * s + 1)] = b[2] + double(ij[1]) * spacing[1];
      xyz[size_t(3 * s + 2)] = b[4] + double(k) * spacing[2];
    }
    inside += field->evaluateMany(xyz.data(), slice, sliceValues.data(), 0);
    for (int64_t s = 0; s < slice; ++s)
      values->SetValue(vtkIdType(k * slice + s), float(sliceValues[size_t(s)]));
  }
  const double total = double(dims[0]) * dims[1] * dims[2];
  if (inside == 0)
  {
    problem = "no sample of the " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
      std::to_string(dims[2]) + " image lies within a particle's radius; raise ParticleRadius or SamplingDimensions";
    return false;
  }
  const double evaluateSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - built).count();
  this->PerSample = evaluateSeconds / total;
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetOrigin(b[0], b[2], b[4]);
  image->SetSpacing(spacing);
  image->SetExtent(0, dims[0] - 1, 0, dims[1] - 1, 0, dims[2] - 1);
  image->GetPointData()->AddArray(values);
  this->Image = image;
  this->Outside = int64_t(total) - inside;
  this->ParticleSet = field;
  this->ParticleBytes = bytes;
  std::ostringstream d;
  d.precision(3);
  d << input->GetClassName() << ", particles: " << field->describe() << " (locator " << buildSeconds
    << " s); reconstructed at " << dims[0] << " x " << dims[1] << " x " << dims[2] << " in " << evaluateSeconds
    << " s (" << this->Outside << " samples outside the support)";
  this->Text = d.str();
  return true;
}

std::shared_ptr<const SourceSamples> InputResampler::ParticleSamples()
{
  // The particles' own positions (an even stride beyond kMaxSourceSamples) with the reconstruction there: the
  // error figures compare the network with the field it was trained on, at the data's own points.
  auto samples = std::make_shared<SourceSamples>();
  samples->Total = this->ParticleSet->counts().Used;
  samples->SourceBytes = this->ParticleBytes;
  const int64_t stride = std::max<int64_t>(
    1, (samples->Total + SourceSamples::kMaxSourceSamples - 1) / SourceSamples::kMaxSourceSamples);
  std::vector<double> xyz;
  int64_t k = 0;
  for (vtkDataSet* leaf : InputLeaves(this->Source))
  {
    if (!leaf->GetPointData()->GetArray(this->Name.c_str()))
      continue;
    for (vtkIdType i = 0; i < leaf->GetNumberOfPoints(); ++i)
    {
      double x[3];
      leaf->GetPoint(i, x);
      if (std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]) && k++ % stride == 0)
        xyz.insert(xyz.end(), x, x + 3);
    }
  }
  std::vector<double> values(xyz.size() / 3);
  this->ParticleSet->evaluateMany(xyz.data(), int64_t(values.size()), values.data(), 0);
  for (size_t i = 0; i < values.size(); ++i)
  {
    if (std::isnan(values[i]))
      continue; // a particle skipped for its value or radius, outside every other one's support
    samples->Xyz.insert(samples->Xyz.end(), &xyz[3 * i], &xyz[3 * i] + 3);
    samples->Values.push_back(values[i]);
  }
  return samples;
}

std::shared_ptr<const ProbedBank> InputResampler::ProbeParticles(
  int64_t count, uint64_t seed, int vectorMode, int component, std::string& problem)
{
  // Seeded random points of the image's box, the reconstruction evaluated at each (a million at a time); those
  // within a particle's support form the bank.
  const auto started = std::chrono::steady_clock::now();
  const double* b = this->ParticleSet->bounds();
  const double lo[3] = { b[0], b[2], b[4] };
  const double len[3] = { b[1] - b[0], b[3] - b[2], b[5] - b[4] };
  auto bank = std::make_shared<ProbedBank>();
  bank->Probed = count;
  // Memory: 44 bytes a point of one chunk (2^20 points) while probing, and the bank's 20 bytes a point inside,
  // reserved from the first chunk's share inside (5% over) rather than grown by doubling.
  const int64_t chunk = int64_t(1) << 20;
  std::vector<float> unit;
  std::vector<double> xyz, values;
  for (int64_t first = 0; first < count; first += chunk)
  {
    const int64_t n = std::min(chunk, count - first);
    unit.resize(size_t(3 * n));
    xyz.resize(size_t(3 * n));
    values.resize(size_t(n));
    RandomBoxPoints(lo, len, seed, first, n, unit.data(), xyz.data()); // the Probe bank's stream
    const int64_t inside = this->ParticleSet->evaluateMany(xyz.data(), n, values.data(), 0);
    if (first == 0)
    {
      const int64_t expected = std::min(count, int64_t(1.05 * double(inside) * double(count) / double(n)) + 1024);
      bank->Xyz.reserve(size_t(3 * expected));
      bank->Values.reserve(size_t(expected));
    }
    for (int64_t i = 0; i < n; ++i)
    {
      if (std::isnan(values[size_t(i)]))
        continue;
      bank->Xyz.insert(bank->Xyz.end(), &unit[size_t(3 * i)], &unit[size_t(3 * i)] + 3);
      bank->Values.push_back(values[size_t(i)]);
    }
  }
  bank->Seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (bank->Values.empty())
  {
    problem = "none of the " + std::to_string(count) + " probed points lies within a particle's radius";
    return nullptr;
  }
  return this->KeepBank(bank, count, seed, vectorMode, component);
}

} // namespace vtkNeuralCompressInternals
