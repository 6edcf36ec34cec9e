#include "vtkNeuralVDBWriter.h"

#include "vtkDataArray.h"
#include "vtkDemandDrivenPipeline.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/Prune.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace
{
/// A sparse grid of `values` (x fastest over dims): voxels within tolerance of the background stay inactive.
template <typename GridT>
typename GridT::Ptr SparseGrid(vtkDataArray* values, const int dims[3], double background, double tolerance)
{
  using V = typename GridT::ValueType;
  const openvdb::CoordBBox box(openvdb::Coord(0, 0, 0), openvdb::Coord(dims[0] - 1, dims[1] - 1, dims[2] - 1));
  openvdb::tools::Dense<V, openvdb::tools::LayoutXYZ> dense(box);
  V* d = dense.data();
  const vtkIdType n = values->GetNumberOfTuples();
  for (vtkIdType i = 0; i < n; ++i)
  {
    const double v = values->GetComponent(i, 0);
    d[i] = static_cast<V>(std::isfinite(v) ? v : background); // NaN: outside the domain -> background
  }
  typename GridT::Ptr grid = GridT::create(static_cast<V>(background));
  openvdb::tools::copyFromDense(dense, *grid, static_cast<V>(tolerance));
  openvdb::tools::prune(grid->tree());
  return grid;
}
} // namespace

vtkStandardNewMacro(vtkNeuralVDBWriter);

vtkNeuralVDBWriter::vtkNeuralVDBWriter()
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(0);
}

vtkNeuralVDBWriter::~vtkNeuralVDBWriter()
{
  this->SetFileName(nullptr);
  this->SetArrayName(nullptr);
}

int vtkNeuralVDBWriter::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkNeuralVDBWriter::Write()
{
  this->Failed = false;
  if (!this->FileName || !*this->FileName || this->GetNumberOfInputConnections(0) < 1)
  {
    vtkErrorMacro("OpenVDB writer: no file name or no input.");
    return 0;
  }
  this->Modified();
  this->Update();
  return this->Failed ? 0 : 1;
}

vtkTypeBool vtkNeuralVDBWriter::ProcessRequest(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  if (!request->Has(vtkDemandDrivenPipeline::REQUEST_DATA()))
  {
    return this->Superclass::ProcessRequest(request, inputVector, outputVector);
  }
  vtkImageData* image = vtkImageData::GetData(inputVector[0], 0);
  try
  {
    if (!image || image->GetNumberOfPoints() == 0)
      throw std::runtime_error("the input image is empty");
    vtkDataArray* values = this->ArrayName && *this->ArrayName ? image->GetPointData()->GetArray(this->ArrayName)
                                                               : image->GetPointData()->GetScalars();
    if (!values && !(this->ArrayName && *this->ArrayName))
      values = image->GetPointData()->GetNumberOfArrays() > 0 ? image->GetPointData()->GetArray(0) : nullptr;
    if (!values)
      throw std::runtime_error("the input has no point array to write (a Neural Compress output needs OutputMode "
                               "\"Decoded, ...\")");
    if (values->GetNumberOfComponents() != 1)
      throw std::runtime_error(std::string("array '") + (values->GetName() ? values->GetName() : "") + "' has " +
        std::to_string(values->GetNumberOfComponents()) + " components; a VDB scalar grid needs one");
    int dims[3];
    image->GetDimensions(dims);
    openvdb::initialize();
    openvdb::GridBase::Ptr grid;
    if (values->GetDataType() == VTK_DOUBLE)
      grid = SparseGrid<openvdb::DoubleGrid>(values, dims, this->Background, this->Tolerance);
    else
      grid = SparseGrid<openvdb::FloatGrid>(values, dims, this->Background, this->Tolerance);
    // world = origin + D diag(spacing) index (row-vector convention: the rows are the scaled axes).
    const double* o = image->GetOrigin();
    const double* s = image->GetSpacing();
    const double* D = image->GetDirectionMatrix()->GetData();
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    for (int a = 0; a < 3; ++a)
      for (int r = 0; r < 3; ++r)
        m(a, r) = D[3 * r + a] * s[a];
    m(3, 0) = o[0];
    m(3, 1) = o[1];
    m(3, 2) = o[2];
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    grid->setName(values->GetName() ? values->GetName() : "density");
    this->ActiveVoxels = static_cast<vtkIdType>(grid->activeVoxelCount());
    openvdb::io::File file(this->FileName);
    file.write({ grid });
    file.close();
  }
  catch (const std::exception& e)
  {
    vtkErrorMacro("OpenVDB writer: " << e.what() << ". Nothing was written.");
    this->Failed = true;
  }
  return 1;
}

void vtkNeuralVDBWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n"
     << indent << "Background: " << this->Background << "\n"
     << indent << "Tolerance: " << this->Tolerance << "\n";
}
