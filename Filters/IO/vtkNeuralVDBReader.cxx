#include "vtkNeuralVDBReader.h"

#include "vtkCellArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"

#include "Core/Error.h"
#include "Core/VdbFileCheck.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>

struct vtkNeuralVDBReader::vtkInternals
{
  openvdb::GridBase::Ptr Grid; ///< read by RequestInformation
  openvdb::CoordBBox Box;      ///< its active voxels' bounding box
};

namespace
{
/// Characters of an exception's text in a message: OpenVDB's texts can quote whole strings of a corrupt file.
constexpr size_t kMaxReportedChars = 300;

/// The text of the exception in flight (called in a catch block), clipped and printable.
std::string CurrentProblem()
{
  std::string text;
  try
  {
    throw;
  }
  catch (const std::bad_alloc&)
  {
    return "OpenVDB ran out of memory reading it: the file is corrupt, or its grid too large for this process";
  }
  catch (const std::exception& e)
  {
    text = e.what() ? e.what() : "";
  }
  catch (...)
  {
    return "an unknown exception while reading it";
  }
  const bool clipped = text.size() > kMaxReportedChars;
  text.resize(std::min(text.size(), kMaxReportedChars));
  for (char& c : text)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e)
      c = '?';
  return clipped ? text + "..." : text;
}

/// The grid `want` (or the first float / double grid; half grids load as float) of a .vdb file.
openvdb::GridBase::Ptr ReadGrid(const std::string& path, const std::string& want)
{
  openvdb::initialize();
  openvdb::io::File file(path);
  file.open(); // throws openvdb::IoError on a missing or non-VDB file
  openvdb::GridPtrVecPtr metas = file.readAllGridMetadata();
  std::string name, names;
  for (const openvdb::GridBase::Ptr& m : *metas)
  {
    names += (names.empty() ? "" : ", ") + m->getName() + " (" + m->type() + ")";
    const bool scalar = m->isType<openvdb::FloatGrid>() || m->isType<openvdb::DoubleGrid>();
    if (name.empty() && (want.empty() ? scalar : m->getName() == want))
    {
      if (!scalar)
        throw std::runtime_error("grid '" + want + "' is a " + m->type() + " grid, not a float, double or half one");
      name = m->getName();
    }
  }
  if (name.empty())
    throw std::runtime_error(want.empty() ? "the file has no float, double or half grid (grids: " + names + ")"
                                          : "the file has no grid '" + want + "' (grids: " + names + ")");
  openvdb::GridBase::Ptr grid = file.readGrid(name);
  file.close();
  if (!grid->transform().isLinear())
    throw std::runtime_error("grid '" + name + "' has a non-linear (frustum) transform, which an image cannot hold");
  return grid;
}

template <typename GridT, typename ArrayT>
void CopyDense(const openvdb::GridBase& base, const openvdb::CoordBBox& box, ArrayT* out)
{
  const GridT& grid = static_cast<const GridT&>(base);
  openvdb::tools::Dense<typename GridT::ValueType, openvdb::tools::LayoutXYZ> dense(box, out->GetPointer(0));
  openvdb::tools::copyToDense(grid, dense);
}

/// One point (the voxel centre through the affine map `m`, OpenVDB's row-vector convention), value and index
/// coordinate per active voxel, in OpenVDB's iteration order; active tiles are expanded to their voxels.
template <typename GridT, typename ArrayT>
void CopyActive(const openvdb::GridBase& base, const openvdb::math::Mat4d& m, vtkIdType n, double* points,
  ArrayT* out, int* coords)
{
  const GridT& grid = static_cast<const GridT&>(base);
  auto* values = out->GetPointer(0);
  vtkIdType id = 0;
  auto put = [&](const openvdb::Coord& c, const typename GridT::ValueType& value) {
    if (id >= n)
      throw std::runtime_error("the grid has more active voxels than it counts");
    const double i = c.x(), j = c.y(), k = c.z();
    for (int r = 0; r < 3; ++r)
      points[3 * id + r] = i * m(0, r) + j * m(1, r) + k * m(2, r) + m(3, r);
    values[id] = value;
    coords[3 * id] = c.x();
    coords[3 * id + 1] = c.y();
    coords[3 * id + 2] = c.z();
    ++id;
  };
  for (typename GridT::ValueOnCIter it = grid.cbeginValueOn(); it; ++it)
  {
    if (it.isVoxelValue())
    {
      put(it.getCoord(), *it);
      continue;
    }
    openvdb::CoordBBox tile;
    it.getBoundingBox(tile);
    const typename GridT::ValueType value = *it;
    openvdb::Coord c;
    for (c[0] = tile.min().x(); c[0] <= tile.max().x(); ++c[0])
      for (c[1] = tile.min().y(); c[1] <= tile.max().y(); ++c[1])
        for (c[2] = tile.min().z(); c[2] <= tile.max().z(); ++c[2])
          put(c, value);
  }
  if (id != n)
    throw std::runtime_error("the grid has fewer active voxels than it counts");
}

/// The active voxels' values (`xyz`: their world positions, `ijk`: their index coordinates) as a double or float
/// array like the grid's; `background`: the grid's background value.
vtkSmartPointer<vtkDataArray> ActiveValues(const openvdb::GridBase& grid, const openvdb::math::Mat4d& m, vtkIdType n,
  vtkDoubleArray* xyz, vtkIntArray* ijk, double& background)
{
  if (grid.isType<openvdb::DoubleGrid>())
  {
    vtkNew<vtkDoubleArray> a;
    a->SetNumberOfTuples(n);
    CopyActive<openvdb::DoubleGrid>(grid, m, n, xyz->GetPointer(0), a.GetPointer(), ijk->GetPointer(0));
    background = static_cast<const openvdb::DoubleGrid&>(grid).background();
    return vtkSmartPointer<vtkDataArray>(a.GetPointer());
  }
  vtkNew<vtkFloatArray> a;
  a->SetNumberOfTuples(n);
  CopyActive<openvdb::FloatGrid>(grid, m, n, xyz->GetPointer(0), a.GetPointer(), ijk->GetPointer(0));
  background = static_cast<const openvdb::FloatGrid&>(grid).background();
  return vtkSmartPointer<vtkDataArray>(a.GetPointer());
}

/// One vertex cell per point.
vtkSmartPointer<vtkCellArray> VertexCells(vtkIdType n)
{
  vtkNew<vtkIdTypeArray> offsets, connectivity;
  offsets->SetNumberOfTuples(n + 1);
  connectivity->SetNumberOfTuples(n);
  for (vtkIdType i = 0; i < n; ++i)
  {
    offsets->SetValue(i, i);
    connectivity->SetValue(i, i);
  }
  offsets->SetValue(n, n);
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  verts->SetData(offsets, connectivity);
  return verts;
}

/// The sparse output's contract in its field data (vtkNeuralCompressSparse.h): background, index box, index-to-world
/// matrix and the grid's name.
void AddSparseContract(vtkFieldData* fieldData, double background, const openvdb::CoordBBox& box,
  const openvdb::math::Mat4d& m, const std::string& gridName)
{
  vtkNew<vtkDoubleArray> bg;
  bg->SetName("VDBBackground");
  bg->InsertNextValue(background);
  vtkNew<vtkIntArray> indexBox;
  indexBox->SetName("VDBIndexBox");
  for (int a = 0; a < 3; ++a)
  {
    indexBox->InsertNextValue(box.min()[a]);
    indexBox->InsertNextValue(box.max()[a]);
  }
  vtkNew<vtkDoubleArray> indexToWorld;
  indexToWorld->SetName("VDBIndexToWorld");
  indexToWorld->SetNumberOfTuples(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) // world = M^T (i, j, k, 1): OpenVDB's matrices act on row vectors
      indexToWorld->SetValue(4 * r + c, r < 3 ? m(c, r) : (c == 3 ? 1.0 : 0.0));
  vtkNew<vtkStringArray> name;
  name->SetName("VDBGridName");
  name->InsertNextValue(gridName);
  fieldData->AddArray(bg);
  fieldData->AddArray(indexBox);
  fieldData->AddArray(indexToWorld);
  fieldData->AddArray(name);
}
} // namespace

vtkStandardNewMacro(vtkNeuralVDBReader);

vtkNeuralVDBReader::vtkNeuralVDBReader()
  : Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(0);
}

vtkNeuralVDBReader::~vtkNeuralVDBReader()
{
  this->SetFileName(nullptr);
  this->SetGridName(nullptr);
}

int vtkNeuralVDBReader::CanReadFile(const char* name)
{
  std::ifstream f(name ? name : "", std::ios::binary);
  unsigned char magic[4] = {};
  f.read(reinterpret_cast<char*>(magic), 4);
  // OpenVDB files start with the 64-bit magic 0x56444220 ("VDB ") in little endian.
  return f.gcount() == 4 && magic[0] == 0x20 && magic[1] == 0x42 && magic[2] == 0x44 && magic[3] == 0x56 ? 1 : 0;
}

int vtkNeuralVDBReader::FillOutputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkDataObject"); // vtkImageData or vtkPolyData: RequestDataObject
  return 1;
}

int vtkNeuralVDBReader::RequestDataObject(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkDataObject* output = vtkDataObject::GetData(outInfo);
  const int type = this->OutputType == ACTIVE_VOXELS ? VTK_POLY_DATA : VTK_IMAGE_DATA;
  if (!output || output->GetDataObjectType() != type)
  {
    vtkSmartPointer<vtkDataObject> created;
    if (type == VTK_POLY_DATA)
      created = vtkSmartPointer<vtkPolyData>::New();
    else
      created = vtkSmartPointer<vtkImageData>::New();
    outInfo->Set(vtkDataObject::DATA_OBJECT(), created);
  }
  return 1;
}

int vtkNeuralVDBReader::RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  this->Internals->Grid.reset();
  outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
  try
  {
    if (!this->FileName || !*this->FileName)
      throw std::runtime_error("no file name");
    // The headers against the file's size first: OpenVDB trusts the lengths and offsets it reads.
    (void)nv::VdbFileCheck::checkFile(this->FileName);
    openvdb::GridBase::Ptr grid = ReadGrid(this->FileName, this->GridName ? this->GridName : "");
    const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
    if (box.empty())
      throw std::runtime_error("grid '" + grid->getName() + "' has no active voxels");
    const openvdb::Coord d = box.dim();
    if (this->OutputType != ACTIVE_VOXELS && double(d.x()) * d.y() * d.z() > double(1 << 30))
      throw std::runtime_error("the active bounding box " + std::to_string(d.x()) + " x " + std::to_string(d.y()) + " x " +
        std::to_string(d.z()) + " exceeds 2^30 voxels");
    this->Internals->Grid = grid;
    this->Internals->Box = box;
  }
  catch (...)
  {
    this->Internals->Grid.reset();
    vtkErrorMacro("OpenVDB reader: '" << (this->FileName ? this->FileName : "") << "': " << CurrentProblem()
                                      << ". The output is empty.");
    return 1;
  }
  if (this->OutputType == ACTIVE_VOXELS)
    return 1; // not structured: no extent
  const openvdb::Coord d = this->Internals->Box.dim();
  const int ext[6] = { 0, d.x() - 1, 0, d.y() - 1, 0, d.z() - 1 };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext, 6);
  return 1;
}

int vtkNeuralVDBReader::RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  if (this->OutputType == ACTIVE_VOXELS)
    return this->RequestActiveVoxels(vtkPolyData::GetData(outputVector, 0));
  vtkImageData* output = vtkImageData::GetData(outputVector, 0);
  if (!output)
  {
    vtkErrorMacro("OpenVDB reader: the output is not an image.");
    return 0;
  }
  output->Initialize();
  openvdb::GridBase::Ptr grid = this->Internals->Grid;
  if (!grid)
    return 1; // reported by RequestInformation
  const openvdb::CoordBBox& box = this->Internals->Box;
  const openvdb::Coord d = box.dim();
  // The transform: world = origin + D diag(spacing) index, from the affine map (row-vector convention).
  const openvdb::math::Mat4d m = grid->transform().baseMap()->getAffineMap()->getMat4();
  const openvdb::Vec3d o = grid->transform().indexToWorld(box.min());
  double spacing[3], dir[9];
  for (int a = 0; a < 3; ++a)
  {
    const double len = std::sqrt(m(a, 0) * m(a, 0) + m(a, 1) * m(a, 1) + m(a, 2) * m(a, 2));
    spacing[a] = len > 0.0 ? len : 1.0;
    for (int r = 0; r < 3; ++r)
      dir[3 * r + a] = len > 0.0 ? m(a, r) / len : (r == a ? 1.0 : 0.0);
  }
  output->SetExtent(0, d.x() - 1, 0, d.y() - 1, 0, d.z() - 1);
  output->SetOrigin(o.x(), o.y(), o.z());
  output->SetSpacing(spacing);
  output->SetDirectionMatrix(dir);
  const vtkIdType n = vtkIdType(d.x()) * d.y() * d.z();
  try
  {
    if (grid->isType<openvdb::DoubleGrid>())
    {
      vtkNew<vtkDoubleArray> values;
      values->SetNumberOfTuples(n);
      CopyDense<openvdb::DoubleGrid>(*grid, box, values.GetPointer());
      values->SetName(grid->getName().empty() ? "density" : grid->getName().c_str());
      output->GetPointData()->SetScalars(values);
    }
    else
    {
      vtkNew<vtkFloatArray> values;
      values->SetNumberOfTuples(n);
      CopyDense<openvdb::FloatGrid>(*grid, box, values.GetPointer());
      values->SetName(grid->getName().empty() ? "density" : grid->getName().c_str());
      output->GetPointData()->SetScalars(values);
    }
  }
  catch (...)
  {
    vtkErrorMacro("OpenVDB reader: '" << this->FileName << "': " << CurrentProblem() << ". The output is empty.");
    output->Initialize();
    return 1;
  }
  this->ActiveVoxels = static_cast<vtkIdType>(grid->activeVoxelCount());
  return 1;
}

int vtkNeuralVDBReader::RequestActiveVoxels(vtkPolyData* output)
{
  if (!output)
  {
    vtkErrorMacro("OpenVDB reader: the output is not a polydata.");
    return 0;
  }
  output->Initialize();
  openvdb::GridBase::Ptr grid = this->Internals->Grid;
  if (!grid)
    return 1; // reported by RequestInformation
  const openvdb::CoordBBox& box = this->Internals->Box;
  try
  {
    const openvdb::math::Mat4d m = grid->transform().baseMap()->getAffineMap()->getMat4();
    const openvdb::Index64 count = grid->activeVoxelCount();
    if (count > openvdb::Index64(std::numeric_limits<vtkIdType>::max() / 3))
      throw std::runtime_error("too many active voxels (" + std::to_string(count) + ")");
    const vtkIdType n = static_cast<vtkIdType>(count);
    const std::string name = grid->getName().empty() ? "density" : grid->getName();

    vtkNew<vtkDoubleArray> xyz;
    xyz->SetNumberOfComponents(3);
    xyz->SetNumberOfTuples(n);
    vtkNew<vtkIntArray> ijk;
    ijk->SetName("VDBCoordinate");
    ijk->SetNumberOfComponents(3);
    ijk->SetNumberOfTuples(n);
    double background = 0.0;
    vtkSmartPointer<vtkDataArray> values = ActiveValues(*grid, m, n, xyz, ijk, background);
    values->SetName(name.c_str());

    vtkNew<vtkPoints> points;
    points->SetData(xyz);
    output->SetPoints(points);
    output->SetVerts(VertexCells(n));
    output->GetPointData()->SetScalars(values);
    output->GetPointData()->AddArray(ijk);
    AddSparseContract(output->GetFieldData(), background, box, m, grid->getName());
  }
  catch (...)
  {
    vtkErrorMacro("OpenVDB reader: '" << this->FileName << "': " << CurrentProblem() << ". The output is empty.");
    output->Initialize();
    return 1;
  }
  this->ActiveVoxels = static_cast<vtkIdType>(grid->activeVoxelCount());
  return 1;
}

void vtkNeuralVDBReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n"
     << indent << "GridName: " << (this->GridName ? this->GridName : "(first scalar grid)") << "\n"
     << indent << "OutputType: " << (this->OutputType == ACTIVE_VOXELS ? "active voxels" : "image") << "\n";
}
