// The Probe bank of InputResampler (vtkNeuralCompressResample.h): seeded random points in the resampled image's box,
// probed in the input's cells (vtkCompositeDataProbeFilter with a static cell locator); particle sets go to their own
// reconstruction (vtkNeuralCompressParticles).
#include "vtkNeuralCompressResample.h"

#include "vtkCompositeDataProbeFilter.h"
#include "vtkDataArray.h"
#include "vtkDataArraySelection.h"
#include "vtkDataSet.h"
#include "vtkImageData.h"
#include "vtkNew.h"
#include "vtkPassSelectedArrays.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkStaticCellLocator.h"

#include "Core/HashGridMath.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace vtkNeuralCompressInternals
{

void RandomBoxPoints(const double lo[3], const double len[3], uint64_t seed, int64_t first, int64_t count,
  float* unit, double* world)
{
  for (int64_t i = 0; i < count; ++i)
  {
    float* u = unit + 3 * i;
    nv::randomPoint(seed, 0x50524F4245ull, uint64_t(first + i), u); // "PROBE": a stream of its own, not the training draws
    for (int a = 0; a < 3; ++a)
    {
      if (!(len[a] > 0.0))
        u[a] = 0.5f; // a flat axis: the network's input there is 0.5
      world[3 * i + a] = lo[a] + (len[a] > 0.0 ? double(u[a]) * len[a] : 0.0);
    }
  }
}

namespace
{
/// `count` seeded random points in the image's box: their world positions (`points`) and their positions normalised
/// to the box (returned, interleaved).
std::vector<float> RandomProbePoints(vtkImageData* image, int64_t count, uint64_t seed, vtkPoints* points)
{
  double lo[3], len[3];
  int ext[6];
  image->GetExtent(ext);
  for (int a = 0; a < 3; ++a)
  {
    lo[a] = image->GetOrigin()[a] + ext[2 * a] * image->GetSpacing()[a];
    len[a] = (ext[2 * a + 1] - ext[2 * a]) * image->GetSpacing()[a];
  }
  std::vector<float> unit(size_t(3 * count));
  std::vector<double> world(size_t(3 * count));
  RandomBoxPoints(lo, len, seed, 0, count, unit.data(), world.data());
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(count);
  for (int64_t i = 0; i < count; ++i)
    points->SetPoint(i, &world[size_t(3 * i)]);
  return unit;
}

/// The probed points inside a cell with a finite value (magnitude or component as vectorMode says) go to `bank`.
void FillProbedBank(vtkDataArray* values, vtkDataArray* mask, const std::vector<float>& unit, int64_t count,
  int vectorMode, int component, ProbedBank& bank)
{
  for (int64_t i = 0; i < count; ++i)
  {
    if (mask->GetComponent(i, 0) == 0.0)
      continue;
    const double v = TupleScalar(values, i, vectorMode, component);
    if (!std::isfinite(v))
      continue;
    bank.Xyz.insert(bank.Xyz.end(), &unit[size_t(3 * i)], &unit[size_t(3 * i)] + 3);
    bank.Values.push_back(v);
  }
}
} // namespace

std::shared_ptr<const ProbedBank> InputResampler::Probe(int64_t count, uint64_t seed, int vectorMode, int component,
  std::string& problem)
{
  if (!this->Input || !this->Image)
  {
    problem = "no resampled input";
    return nullptr;
  }
  if (this->Bank && this->BankCount == count && this->BankSeed == seed && this->BankMode == vectorMode &&
    this->BankComponent == component)
    return this->Bank;
  if (this->ParticleSet)
    return this->ProbeParticles(count, seed, vectorMode, component, problem);
  const auto t0 = std::chrono::steady_clock::now();
  // The image's box: the bank's points are normalised to it as the network's inputs are.
  vtkNew<vtkPoints> points;
  const std::vector<float> unit = RandomProbePoints(this->Image, count, seed, points);
  vtkNew<vtkPolyData> where;
  where->SetPoints(points);
  vtkNew<vtkPassSelectedArrays> pass;
  pass->SetInputDataObject(this->Source);
  pass->GetArraySelection(this->Association)->EnableArray(this->Name.c_str());
  vtkNew<vtkCompositeDataProbeFilter> probe;
  probe->SetInputData(where);
  probe->SetSourceConnection(pass->GetOutputPort());
  vtkNew<vtkStaticCellLocator> locator;
  probe->SetCellLocatorPrototype(locator);
  probe->PassPointArraysOff();
  probe->PassCellArraysOff();
  probe->PassFieldArraysOff();
  probe->Update();
  vtkDataSet* out = vtkDataSet::SafeDownCast(probe->GetOutputDataObject(0));
  vtkDataArray* values = out ? out->GetPointData()->GetArray(this->Name.c_str()) : nullptr;
  vtkDataArray* mask = out ? out->GetPointData()->GetArray(probe->GetValidPointMaskArrayName()) : nullptr;
  if (!values || !mask || values->GetNumberOfTuples() != count || mask->GetNumberOfTuples() != count)
  {
    problem = "probing the input gave no '" + this->Name + "' values";
    return nullptr;
  }
  auto bank = std::make_shared<ProbedBank>();
  bank->Probed = count;
  FillProbedBank(values, mask, unit, count, vectorMode, component, *bank);
  if (bank->Values.empty())
  {
    problem = "none of the " + std::to_string(count) + " probed points lies inside a cell of the input";
    return nullptr;
  }
  bank->Seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return this->KeepBank(bank, count, seed, vectorMode, component);
}

std::shared_ptr<const ProbedBank> InputResampler::KeepBank(
  std::shared_ptr<const ProbedBank> bank, int64_t count, uint64_t seed, int vectorMode, int component)
{
  this->Bank = bank;
  this->BankCount = count;
  this->BankSeed = seed;
  this->BankMode = vectorMode;
  this->BankComponent = component;
  return this->Bank;
}

} // namespace vtkNeuralCompressInternals
