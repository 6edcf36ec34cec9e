#include "vtkNeuralOutOfCoreReader.h"

#include "vtkNeuralHdf5Layout.h"
#include "vtkNeuralOutOfCoreInput.h"

#include "Core/Error.h"
#include "Core/Model.h"
#include "OutOfCore/VolumeFileLayout.h"

#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <algorithm>

namespace nvi = vtkNeuralCompressInternals;

vtkStandardNewMacro(vtkNeuralOutOfCoreReader);

vtkNeuralOutOfCoreReader::vtkNeuralOutOfCoreReader()
{
  this->SetNumberOfInputPorts(0);
}

vtkNeuralOutOfCoreReader::~vtkNeuralOutOfCoreReader()
{
  this->SetFileName(nullptr);
  this->SetArrayName(nullptr);
}

int vtkNeuralOutOfCoreReader::CanReadFile(const char* name)
{
  try
  {
    nvi::ReadOutOfCoreLayout(name ? name : "", std::string());
    return 1;
  }
  catch (const std::exception&)
  {
    return 0;
  }
}

int vtkNeuralOutOfCoreReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  this->LayoutRead = false;
  try
  {
    if (!this->FileName || !*this->FileName)
      throw nv::Error("no file name");
    const nv::VolumeFileLayout layout =
      nvi::ReadOutOfCoreLayout(this->FileName, this->ArrayName ? this->ArrayName : "");
    const int ext[6] = { 0, int(layout.dims[0] - 1), 0, int(layout.dims[1] - 1), 0, int(layout.dims[2] - 1) };
    if (layout.dims[0] > VTK_INT_MAX || layout.dims[1] > VTK_INT_MAX || layout.dims[2] > VTK_INT_MAX)
      throw nv::Error("more than 2^31 samples along an axis");
    // What a network can state, checked at the header: not after a pass over the whole file.
    nv::SourceInfo grid;
    for (int axis = 0; axis < 3; ++axis)
      grid.dims[axis] = layout.dims[axis];
    nv::validate(grid);
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext, 6);
    outInfo->Set(vtkDataObject::SPACING(), layout.spacing, 3);
    outInfo->Set(vtkDataObject::ORIGIN(), layout.origin, 3);
    this->Summary = nvi::OutOfCoreSummary(layout);
    this->FieldName = layout.arrayName;
    this->LayoutRead = true;
  }
  catch (const std::exception& e)
  {
    this->Summary = e.what();
    this->FieldName.clear();
    // An empty extent (an empty output), not a failed request: the one error below is the file's.
    const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), empty, 6);
    vtkErrorMacro("Neural Out Of Core Reader: " << e.what() << ". The output is empty.");
  }
  return 1;
}

int vtkNeuralOutOfCoreReader::RequestData(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkImageData* output = vtkImageData::GetData(outInfo);
  output->Initialize();
  if (!this->LayoutRead)
    return 1; // the error was reported by RequestInformation
  try
  {
    // The header again (cheap): the file may have changed since RequestInformation; the samples stay on disk.
    const nv::VolumeFileLayout layout =
      nvi::ReadOutOfCoreLayout(this->FileName, this->ArrayName ? this->ArrayName : "");
    // The extent asked for within the file's (under MPI, Neural Compress asks each rank's padded piece: the rank's
    // Neural Compress then reads only that box of the file); the whole file by default.
    int extent[6] = { 0, int(layout.dims[0] - 1), 0, int(layout.dims[1] - 1), 0, int(layout.dims[2] - 1) };
    if (outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT()))
    {
      int asked[6];
      outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), asked);
      for (int a = 0; a < 3; ++a)
      {
        extent[2 * a] = std::max(extent[2 * a], asked[2 * a]);
        extent[2 * a + 1] = std::min(extent[2 * a + 1], asked[2 * a + 1]);
      }
      if (extent[0] > extent[1] || extent[2] > extent[3] || extent[4] > extent[5])
        return 1; // an empty piece: an empty output (this rank has no piece of the file)
    }
    output->SetExtent(extent);
    output->SetSpacing(layout.spacing);
    output->SetOrigin(layout.origin);
    nvi::MarkOutOfCore(output, layout, this->ArrayName ? this->ArrayName : "");
  }
  catch (const std::exception& e)
  {
    output->Initialize();
    vtkErrorMacro("Neural Out Of Core Reader: " << e.what() << ". The output is empty.");
  }
  return 1;
}

void vtkNeuralOutOfCoreReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName ? this->FileName : "(none)") << "\n";
  os << indent << "ArrayName: " << (this->ArrayName ? this->ArrayName : "(none)") << "\n";
  os << indent << "Summary: " << this->Summary << "\n";
}
