#include "vtkNeuralParticleField.h"

#include "vtkNeuralCompressParticles.h"
#include "vtkNeuralCompressResample.h"

#include "vtkCharArray.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkDataSetAttributes.h"
#include "vtkSmartPointer.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <cmath>

namespace nvi = vtkNeuralCompressInternals;

vtkStandardNewMacro(vtkNeuralParticleField);

vtkNeuralParticleField::vtkNeuralParticleField()
{
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
}

vtkNeuralParticleField::~vtkNeuralParticleField() = default;

void vtkNeuralParticleField::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "ParticleField: " << this->ParticleField << "\n"
     << indent << "ParticleKernel: " << this->ParticleKernel << "\n"
     << indent << "ParticleRadius: " << this->ParticleRadius << "\n"
     << indent << "ParticleRadiusArray: " << this->ParticleRadiusArray << "\n";
}

int vtkNeuralParticleField::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataObject");
  return 1;
}

std::string vtkNeuralParticleField::ArrayName()
{
  vtkInformation* ai = this->GetInputArrayInformation(0);
  const char* name = ai && ai->Has(vtkDataObject::FIELD_NAME()) ? ai->Get(vtkDataObject::FIELD_NAME()) : nullptr;
  return name ? name : "";
}

int vtkNeuralParticleField::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkDataObject* input = vtkDataObject::GetData(inputVector[0], 0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  int dims[3] = { 1, 1, 1 };
  std::string problem;
  const std::string name = this->ArrayName();
  if (input && nvi::IsParticleSet(input) && !name.empty())
    nvi::ResolveParticleDimensions(
      input, name, vtkDataObject::FIELD_ASSOCIATION_POINTS, this->SamplingDimensions, dims, problem);
  const int extent[6] = { 0, dims[0] - 1, 0, dims[1] - 1, 0, dims[2] - 1 };
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  return 1;
}

int vtkNeuralParticleField::RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*)
{
  return 1; // the whole particle set, whatever extent is asked
}

int vtkNeuralParticleField::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkDataObject* input = vtkDataObject::GetData(inputVector[0], 0);
  vtkImageData* output = vtkImageData::GetData(outputVector, 0);
  this->Description.clear();
  const std::string name = this->ArrayName();
  if (!input || !nvi::IsParticleSet(input))
  {
    vtkErrorMacro("Neural Particle Field: the input is not a particle set (poly data of vertices or points only, an "
                  "unstructured grid of vertex cells).");
    return 0;
  }
  if (name.empty())
  {
    vtkErrorMacro("Neural Particle Field: no input array. Select a point array of the particles.");
    return 0;
  }
  nvi::ParticleSettings settings;
  settings.Field = this->ParticleField;
  settings.Kernel = this->ParticleKernel;
  settings.Radius = this->ParticleRadius;
  settings.RadiusArray = this->ParticleRadiusArray;
  nvi::InputResampler resampler;
  resampler.SetParticleSettings(settings);
  vtkSmartPointer<vtkImageData> image;
  int64_t outside = 0;
  std::string problem;
  if (!resampler.Resample(input, name, vtkDataObject::FIELD_ASSOCIATION_POINTS, this->SamplingDimensions, image,
        outside, problem, nullptr, 0))
  {
    vtkErrorMacro("Neural Particle Field: " << problem << ".");
    return 0;
  }
  output->ShallowCopy(image);
  vtkDataArray* values = output->GetPointData()->GetArray(name.c_str());
  vtkNew<vtkCharArray> mask;
  mask->SetName("vtkValidPointMask");
  mask->SetNumberOfTuples(values->GetNumberOfTuples());
  for (vtkIdType i = 0; i < values->GetNumberOfTuples(); ++i)
    mask->SetValue(i, std::isnan(values->GetComponent(i, 0)) ? 0 : 1);
  output->GetPointData()->AddArray(mask);
  output->GetPointData()->SetActiveScalars(name.c_str());
  this->Description = resampler.Description();
  return 1;
}
