#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressJob.h"

#include "vtkCell.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkDataArraySelection.h"
#include "vtkDataObject.h"
#include "vtkDataSet.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkGenericCell.h"
#include "vtkImageData.h"
#include "vtkNew.h"
#include "vtkOverlappingAMR.h"
#include "vtkPassSelectedArrays.h"
#include "vtkPointData.h"
#include "vtkPointSet.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkResampleToImage.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include "Core/HashGridMath.h"

#include <chrono>

#include <algorithm>
#include <cstring>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace vtkNeuralCompressInternals
{
namespace
{
constexpr double kMinSamples = 32.0 * 32.0 * 32.0;
constexpr double kMaxSamples = 256.0 * 256.0 * 256.0;

vtkDataArray* FieldArray(vtkDataSet* ds, const std::string& name, int association)
{
  return association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? ds->GetCellData()->GetArray(name.c_str())
                                                                : ds->GetPointData()->GetArray(name.c_str());
}
} // namespace

std::vector<vtkDataSet*> InputLeaves(vtkDataObject* input)
{
  std::vector<vtkDataSet*> out;
  if (auto* ds = vtkDataSet::SafeDownCast(input))
  {
    out.push_back(ds);
  }
  else if (auto* cd = vtkCompositeDataSet::SafeDownCast(input))
  {
    vtkSmartPointer<vtkCompositeDataIterator> it;
    it.TakeReference(cd->NewIterator());
    for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
    {
      if (auto* leaf = vtkDataSet::SafeDownCast(it->GetCurrentDataObject()))
      {
        out.push_back(leaf);
      }
    }
  }
  return out;
}

double TupleScalar(vtkDataArray* array, vtkIdType i, int vectorMode, int component)
{
  const int nc = array->GetNumberOfComponents();
  if (nc == 1 || vectorMode == 1)
    return array->GetComponent(i, nc == 1 ? 0 : std::min(std::max(component, 0), nc - 1));
  double sum = 0.0;
  for (int q = 0; q < nc; ++q)
    sum += array->GetComponent(i, q) * array->GetComponent(i, q);
  return std::sqrt(sum);
}

bool InputBounds(vtkDataObject* input, double bounds[6])
{
  bool any = false;
  for (vtkDataSet* leaf : InputLeaves(input))
  {
    if (leaf->GetNumberOfPoints() == 0)
      continue;
    double b[6];
    leaf->GetBounds(b);
    for (int a = 0; a < 3; ++a)
    {
      bounds[2 * a] = any ? std::min(bounds[2 * a], b[2 * a]) : b[2 * a];
      bounds[2 * a + 1] = any ? std::max(bounds[2 * a + 1], b[2 * a + 1]) : b[2 * a + 1];
    }
    any = true;
  }
  return any;
}

uint64_t InputStamp(vtkDataObject* input, const std::string& name, int association)
{
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](uint64_t v) {
    for (int b = 0; b < 8; ++b)
      h = (h ^ ((v >> (8 * b)) & 0xffu)) * 1099511628211ull;
  };
  for (vtkDataSet* leaf : InputLeaves(input))
  {
    mix(reinterpret_cast<uintptr_t>(leaf));
    vtkDataArray* array = FieldArray(leaf, name, association);
    mix(reinterpret_cast<uintptr_t>(array));
    mix(array ? array->GetMTime() : 0);
    if (auto* points = vtkPointSet::SafeDownCast(leaf))
      mix(points->GetPoints() ? points->GetPoints()->GetMTime() : 0);
    if (auto* grid = vtkUnstructuredGrid::SafeDownCast(leaf))
      mix(grid->GetCells() ? grid->GetCells()->GetMTime() : 0);
    if (auto* poly = vtkPolyData::SafeDownCast(leaf))
      mix(poly->GetNumberOfCells());
    double bounds[6];
    leaf->GetBounds(bounds);
    for (double b : bounds)
    {
      uint64_t bits;
      std::memcpy(&bits, &b, sizeof(bits));
      mix(bits);
    }
  }
  return h;
}

void AutoSamplingDimensions(const double bounds[6], int64_t sourceSamples, double finestSpacing, int dims[3])
{
  double len[3];
  int active = 0;
  double largest = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    len[a] = std::max(0.0, bounds[2 * a + 1] - bounds[2 * a]);
    largest = std::max(largest, len[a]);
  }
  for (int a = 0; a < 3; ++a)
  {
    // An axis under a millionth of the largest extent is flat: one sample.
    if (len[a] <= 1e-6 * largest)
      len[a] = 0.0;
    active += len[a] > 0.0 ? 1 : 0;
  }
  double want = 27.0 * static_cast<double>(std::max<int64_t>(sourceSamples, 1));
  if (finestSpacing > 0.0 && active > 0)
  {
    want = 1.0;
    for (int a = 0; a < 3; ++a)
      want *= len[a] > 0.0 ? len[a] / finestSpacing + 1.0 : 1.0;
  }
  const double maxTotal = active == 3 ? kMaxSamples : active == 2 ? 4096.0 * 4096.0 : 1 << 20;
  const double minTotal = active == 3 ? kMinSamples : active == 2 ? 64.0 * 64.0 : 256.0;
  want = std::min(std::max(want, minTotal), maxTotal);
  double volume = 1.0;
  for (int a = 0; a < 3; ++a)
    volume *= len[a] > 0.0 ? len[a] : 1.0;
  const double h = active > 0 ? std::pow(volume / want, 1.0 / active) : 1.0;
  for (int a = 0; a < 3; ++a)
  {
    dims[a] = len[a] > 0.0 ? static_cast<int>(std::max(2.0, std::round(len[a] / h) + 1.0)) : 1;
  }
}

namespace
{
/// The array: present in at least one leaf, never on poly data that is a surface in 3D; `samples`: the points or
/// cells of the leaves that have it. False with `problem` set otherwise.
bool CountArraySamples(const std::vector<vtkDataSet*>& leaves, const std::string& name, int association,
  int64_t& samples, std::string& problem)
{
  int64_t withArray = 0;
  bool flat3d = false;
  for (vtkDataSet* leaf : leaves)
  {
    vtkDataArray* a = FieldArray(leaf, name, association);
    if (!a)
      continue;
    ++withArray;
    samples += association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? leaf->GetNumberOfCells()
                                                                     : leaf->GetNumberOfPoints();
    if (auto* pd = vtkPolyData::SafeDownCast(leaf))
    {
      double b[6];
      pd->GetBounds(b);
      const double lx = b[1] - b[0], ly = b[3] - b[2], lz = b[5] - b[4];
      const double largest = std::max(lx, std::max(ly, lz));
      flat3d |= std::min(lx, std::min(ly, lz)) > 1e-6 * largest;
    }
  }
  if (withArray == 0)
  {
    problem = "no block of the input has a " +
      std::string(association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? "cell" : "point") + " array '" + name + "'";
    return false;
  }
  if (flat3d)
  {
    problem = "poly data is a surface, line or point set in 3D and has no volume to sample; Neural Compress "
              "takes volumes (image, rectilinear, structured, unstructured grids, AMR) or planar poly data";
    return false;
  }
  return true;
}

/// The input's bounds; false with `problem` set when they are not valid (no points).
bool ValidBounds(vtkDataObject* input, double bounds[6], std::string& problem)
{
  if (auto* ds = vtkDataSet::SafeDownCast(input))
    ds->GetBounds(bounds);
  else if (auto* amr = vtkUniformGridAMR::SafeDownCast(input))
    amr->GetBounds(bounds);
  else
    vtkCompositeDataSet::SafeDownCast(input)->GetBounds(bounds);
  if (!(bounds[1] >= bounds[0] && bounds[3] >= bounds[2] && bounds[5] >= bounds[4]) ||
    !std::isfinite(bounds[0] + bounds[1] + bounds[2] + bounds[3] + bounds[4] + bounds[5]))
  {
    problem = "the input has no valid bounds (no points)";
    return false;
  }
  return true;
}

/// Composites of images (AMR, multiblocks of grids): the finest spacing of their blocks with the array (0: none).
double FinestBlockSpacing(
  vtkDataObject* input, const std::vector<vtkDataSet*>& leaves, const std::string& name, int association)
{
  double finest = 0.0;
  if (!vtkDataSet::SafeDownCast(input))
  {
    for (vtkDataSet* leaf : leaves)
    {
      auto* im = vtkImageData::SafeDownCast(leaf);
      if (!im || !FieldArray(leaf, name, association))
        continue;
      const double* h = im->GetSpacing();
      int ext[6];
      im->GetExtent(ext);
      for (int a = 0; a < 3; ++a)
        if (ext[2 * a + 1] > ext[2 * a] && h[a] > 0.0)
          finest = finest > 0.0 ? std::min(finest, h[a]) : h[a];
    }
  }
  return finest;
}
} // namespace

bool ResolveSamplingDimensions(vtkDataObject* input, const std::string& name, int association,
  const int requested[3], int dims[3], std::string& problem)
{
  if (!input)
  {
    problem = "no input";
    return false;
  }
  if (IsParticleSet(input))
    return ResolveParticleDimensions(input, name, association, requested, dims, problem);
  const std::vector<vtkDataSet*> leaves = InputLeaves(input);
  int64_t samples = 0;
  double bounds[6];
  if (!CountArraySamples(leaves, name, association, samples, problem) || !ValidBounds(input, bounds, problem))
    return false;
  // The finest spacing of a composite's image blocks sets the resolution.
  const double finest = FinestBlockSpacing(input, leaves, name, association);
  std::copy(requested, requested + 3, dims);
  if (dims[0] <= 0 || dims[1] <= 0 || dims[2] <= 0)
  {
    AutoSamplingDimensions(bounds, samples, finest, dims);
  }
  const double total = double(dims[0]) * dims[1] * dims[2];
  if (total > 1024.0 * 1024.0 * 1024.0)
  {
    std::ostringstream s;
    s << "SamplingDimensions " << dims[0] << " x " << dims[1] << " x " << dims[2]
      << " exceed 2^30 samples; choose at most 1024^3";
    problem = s.str();
    return false;
  }

  return true;
}

namespace
{
/// A floating-point copy of the resampled `values` with NaN where the image point is outside every cell (`mask` 0);
/// `outside` counts those points.
vtkSmartPointer<vtkDataArray> MaskedCopy(
  vtkDataArray* values, vtkDataArray* mask, const std::string& name, int64_t& outside)
{
  const vtkIdType n = values->GetNumberOfTuples();
  const int nc = values->GetNumberOfComponents();
  vtkSmartPointer<vtkDataArray> field;
  if (values->GetDataType() == VTK_DOUBLE)
    field = vtkSmartPointer<vtkDoubleArray>::New();
  else
    field = vtkSmartPointer<vtkFloatArray>::New();
  field->SetName(name.c_str());
  field->SetNumberOfComponents(nc);
  field->SetNumberOfTuples(n);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  outside = 0;
  for (vtkIdType i = 0; i < n; ++i)
  {
    const bool in = mask->GetComponent(i, 0) != 0.0;
    outside += in ? 0 : 1;
    for (int c = 0; c < nc; ++c)
      field->SetComponent(i, c, in ? values->GetComponent(i, c) : nan);
  }
  return field;
}

/// What a resampling did, for the field's description.
std::string ResampleDescription(vtkDataObject* input, const std::vector<vtkDataSet*>& leaves, const std::string& name,
  int association, const int dims[3], int64_t outside)
{
  int64_t samples = 0, withArray = 0;
  for (vtkDataSet* leaf : leaves)
  {
    if (vtkDataArray* a = FieldArray(leaf, name, association))
    {
      ++withArray;
      samples += a->GetNumberOfTuples();
    }
  }
  std::ostringstream d;
  d << input->GetClassName();
  if (leaves.size() != 1 || !vtkDataSet::SafeDownCast(input))
    d << " (" << withArray << " of " << leaves.size() << " blocks with '" << name << "')";
  d << ", " << samples << (association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? " cells" : " points")
    << " resampled to " << dims[0] << " x " << dims[1] << " x " << dims[2] << " (" << outside
    << " samples outside the domain)";
  return d.str();
}
} // namespace

bool InputResampler::Resample(vtkDataObject* input, const std::string& name, int association, const int dimsIn[3],
  vtkSmartPointer<vtkImageData>& image, int64_t& outside, std::string& problem, const void* source,
  vtkMTimeType sourceMTime)
{
  if (!input)
  {
    problem = "no input";
    return false;
  }
  if (this->Image && this->Input == source && this->InputMTime == sourceMTime && this->Name == name &&
    this->Association == association && std::equal(dimsIn, dimsIn + 3, this->Dims) &&
    this->ResampledParticles == this->Particles)
  {
    image = this->Image;
    outside = this->Outside;
    return true;
  }
  this->Image = nullptr;
  this->ParticleSet = nullptr;
  int dims[3];
  if (!ResolveSamplingDimensions(input, name, association, dimsIn, dims, problem))
    return false;
  vtkSmartPointer<vtkImageData> img;
  int64_t out0 = 0;
  if (IsParticleSet(input))
  {
    if (!this->ResampleParticles(input, name, association, dims, problem))
      return false;
    img = this->Image;
    out0 = this->Outside;
  }
  else
  {
    // Only the selected array (and the ghost arrays AMR blanking needs) is probed.
    vtkNew<vtkPassSelectedArrays> pass;
    pass->SetInputDataObject(input);
    pass->GetArraySelection(association)->EnableArray(name.c_str());
    vtkNew<vtkResampleToImage> resample;
    resample->SetInputConnection(pass->GetOutputPort());
    resample->SetUseInputBounds(true);
    resample->SetSamplingDimensions(dims);
    const auto started = std::chrono::steady_clock::now();
    resample->Update();
    this->PerSample = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() /
      (double(dims[0]) * dims[1] * dims[2]);
    vtkImageData* out = resample->GetOutput();
    vtkDataArray* values = out ? out->GetPointData()->GetArray(name.c_str()) : nullptr;
    vtkDataArray* mask = out ? out->GetPointData()->GetArray(resample->GetMaskArrayName()) : nullptr;
    if (!values || !mask || mask->GetNumberOfTuples() != values->GetNumberOfTuples())
    {
      problem = "resampling the input to an image gave no '" + name + "' values";
      return false;
    }

    vtkSmartPointer<vtkDataArray> field = MaskedCopy(values, mask, name, out0);
    if (out0 == values->GetNumberOfTuples())
    {
      problem = "no sample of the " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
        std::to_string(dims[2]) + " resampling lies inside a cell of the input";
      return false;
    }
    img = vtkSmartPointer<vtkImageData>::New();
    img->SetOrigin(out->GetOrigin());
    img->SetSpacing(out->GetSpacing());
    img->SetExtent(out->GetExtent());
    img->GetPointData()->AddArray(field);
    this->Text = ResampleDescription(input, InputLeaves(input), name, association, dims, out0);
  }
  this->ResampledParticles = this->Particles;
  this->Input = source;
  this->InputMTime = sourceMTime;
  this->Source = input;
  this->Name = name;
  this->Association = association;
  std::copy(dimsIn, dimsIn + 3, this->Dims);
  this->Image = img;
  this->Outside = out0;
  this->Cached = nullptr;
  this->Bank = nullptr;
  image = img;
  outside = out0;
  return true;
}

std::shared_ptr<const SourceSamples> InputResampler::Samples(int vectorMode, int component)
{
  if (!this->Input || !this->Image)
    return nullptr;
  if (this->Cached && this->SamplesMode == vectorMode && this->SamplesComponent == component)
    return this->Cached;
  if (this->ParticleSet)
    return this->Cached = this->ParticleSamples(); // the settings' vector mode made the field
  const bool cells = this->Association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  // Cells hidden by a finer AMR level or duplicated as ghosts are not the source's own samples.
  const unsigned char skipCell = vtkDataSetAttributes::DUPLICATECELL | vtkDataSetAttributes::HIDDENCELL |
    vtkDataSetAttributes::REFINEDCELL;
  const unsigned char skipPoint = vtkDataSetAttributes::DUPLICATEPOINT | vtkDataSetAttributes::HIDDENPOINT;
  auto samples = std::make_shared<SourceSamples>();
  struct Leaf
  {
    vtkDataSet* dataSet;
    vtkDataArray* array;
    vtkUnsignedCharArray* ghost;
  };
  std::vector<Leaf> leaves;
  for (vtkDataSet* leaf : InputLeaves(this->Source))
  {
    vtkDataArray* a = FieldArray(leaf, this->Name, this->Association);
    if (!a)
      continue;
    samples->SourceBytes += int64_t(a->GetNumberOfValues()) * std::max(1, a->GetDataTypeSize());
    vtkUnsignedCharArray* ghost = cells ? leaf->GetCellGhostArray() : leaf->GetPointGhostArray();
    leaves.push_back({ leaf, a, ghost });
    const vtkIdType n = a->GetNumberOfTuples();
    for (vtkIdType i = 0; i < n; ++i)
      samples->Total += ghost && (ghost->GetValue(i) & (cells ? skipCell : skipPoint)) ? 0 : 1;
  }
  const int64_t stride =
    std::max<int64_t>(1, (samples->Total + SourceSamples::kMaxSourceSamples - 1) / SourceSamples::kMaxSourceSamples);
  vtkNew<vtkGenericCell> cell;
  std::vector<double> weights;
  int64_t k = 0;
  for (const Leaf& l : leaves)
  {
    const vtkIdType n = l.array->GetNumberOfTuples();
    for (vtkIdType i = 0; i < n; ++i)
    {
      if (l.ghost && (l.ghost->GetValue(i) & (cells ? skipCell : skipPoint)))
        continue;
      if (k++ % stride != 0)
        continue;
      double x[3];
      if (cells)
      {
        // Parametric centre of the cell, mapped to world coordinates.
        l.dataSet->GetCell(i, cell);
        double pc[3];
        weights.resize(size_t(std::max<vtkIdType>(cell->GetNumberOfPoints(), 1)));
        int sub = cell->GetParametricCenter(pc);
        cell->EvaluateLocation(sub, pc, x, weights.data());
      }
      else
      {
        l.dataSet->GetPoint(i, x);
      }
      samples->Xyz.insert(samples->Xyz.end(), x, x + 3);
      samples->Values.push_back(TupleScalar(l.array, i, vectorMode, component));
    }
  }
  this->SamplesMode = vectorMode;
  this->SamplesComponent = component;
  this->Cached = samples;
  return samples;
}

} // namespace vtkNeuralCompressInternals
