// vtkNeuralCompress::Execute and its steps: the input and its selected array (an image, or a dataset resampled onto
// one), the field the network is trained on, and the job that trains it when the input or the settings changed.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressDecode.h"
#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressSparse.h"
#include "vtkNeuralCompressState.h"

#include "Core/Error.h"
#include "Core/ValueRange.h"

#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkMatrix3x3.h"
#include "vtkPointData.h"
#include "vtkSmartPointer.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace vtkNeuralCompressInternals
{
/// The image Execute trains from and its selected array.
struct SelectedInput
{
  vtkImageData* Image = nullptr;           ///< the input image, or the resampled one
  vtkSmartPointer<vtkImageData> Resampled; ///< keeps a resampled image alive
  vtkDataArray* Array = nullptr;
  int Association = -1;
  /// Inputs resampled to an image: 1 for the points outside the source's domain (FieldInfo::Outside); null for images.
  std::shared_ptr<std::vector<uint8_t>> Outside;
};
} // namespace vtkNeuralCompressInternals

//------------------------------------------------------------------------------
bool vtkNeuralCompress::Execute(vtkDataObject* inputObject, vtkInformationVector** inputVector,
  vtkImageData* output, vtkTable* log, vtkTable* metrics, double time)
{
  if (!vtkImageData::SafeDownCast(inputObject) && nvi::IsSparseVoxels(inputObject))
  {
    return this->ExecuteSparse(inputObject, output, log, metrics, time);
  }
  nvi::SelectedInput input;
  if (!this->SelectInput(inputObject, inputVector, input))
  {
    return false;
  }
  try
  {
    nvi::Settings settings = this->CurrentSettings();
    if (!input.Outside)
      settings.Sampling = settings.ProbePoints = 0; // images are their own samples: Sampling does not apply
    const std::string canonical = settings.Canonical();
    if (this->IsCurrentTraining(input.Array, canonical, time))
    {
      return this->EmitOutputs(output, log, metrics); // a live refresh or a control: same training
    }
    nvi::FieldInfo field;
    if (!this->DescribeField(input, field))
    {
      return false;
    }
    auto data = std::make_shared<nvi::TrainingData>();
    if (!this->ReadField(input, field, *data))
    {
      return false;
    }
    if (input.Outside && this->Sampling == SAMPLING_PROBE && !this->ProbeTrainingPoints(inputObject, field, *data))
    {
      return false;
    }
    data->Field.View.valueMin = field.Stats.min;
    data->Field.View.valueMax = field.Stats.max;
    this->StartJobIfChanged(input.Array, field, data, settings, canonical, time);
    return this->EmitOutputs(output, log, metrics);
  }
  catch (const nv::Error& e)
  {
    vtkErrorMacro("Neural Compress: " << e.what());
  }
  catch (const std::bad_alloc&)
  {
    vtkErrorMacro("Neural Compress: out of memory. Lower Log2TableSize, BatchSize or OutputResolution. The output is "
                  "empty.");
  }
  catch (const std::exception& e)
  {
    vtkErrorMacro("Neural Compress: unexpected failure: " << e.what());
  }
  return false;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::SelectInput(
  vtkDataObject* inputObject, vtkInformationVector** inputVector, nvi::SelectedInput& input)
{
  input.Image = vtkImageData::SafeDownCast(inputObject);
  if (input.Image)
  {
    input.Array = this->GetInputArrayToProcess(0, inputVector, input.Association);
  }
  else if (!this->ResampleInput(inputObject, input))
  {
    return false;
  }
  if (input.Image->GetNumberOfPoints() == 0)
  {
    vtkErrorMacro("Neural Compress: the input image has an empty extent; nothing to train on. "
                  "The output is empty.");
    return false;
  }
  if (!input.Array)
  {
    vtkErrorMacro("Neural Compress: no input array. Select a numeric point or cell array of the "
                  "image (SelectInputScalars). The output is empty.");
    return false;
  }
  if (input.Association != vtkDataObject::FIELD_ASSOCIATION_POINTS &&
    input.Association != vtkDataObject::FIELD_ASSOCIATION_CELLS)
  {
    vtkErrorMacro("Neural Compress: array '" << (input.Array->GetName() ? input.Array->GetName() : "")
                                             << "' is neither a point nor a cell array. "
                                                "The output is empty.");
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ResampleInput(vtkDataObject* inputObject, nvi::SelectedInput& input)
{
  vtkInternals& in = *this->Internals;
  // Not an image: resampled onto one (vtkNeuralCompressResample.h), cached across re-executions.
  if (!vtkDataSet::SafeDownCast(inputObject) && !vtkCompositeDataSet::SafeDownCast(inputObject))
  {
    vtkErrorMacro("Neural Compress: " << (inputObject ? inputObject->GetClassName() : "no")
                                      << " input; a dataset or composite dataset is needed. The output is empty.");
    return false;
  }
  vtkInformation* ai = this->GetInputArrayInformation(0);
  const char* name = ai && ai->Has(vtkDataObject::FIELD_NAME()) ? ai->Get(vtkDataObject::FIELD_NAME()) : nullptr;
  const int assoc = ai && ai->Has(vtkDataObject::FIELD_ASSOCIATION()) ? ai->Get(vtkDataObject::FIELD_ASSOCIATION()) : -1;
  if (!name || !*name ||
    (assoc != vtkDataObject::FIELD_ASSOCIATION_POINTS && assoc != vtkDataObject::FIELD_ASSOCIATION_CELLS))
  {
    vtkErrorMacro("Neural Compress: no input array. Select a numeric point or cell array "
                  "(SelectInputScalars). The output is empty.");
    return false;
  }
  int64_t outsideCount = 0;
  std::string problem;
  int dims[3];
  // The dimensions RequestInformation announced (from the input data it saw), else resolved now.
  if (in.AnnouncedDims[0] > 0)
    std::copy(in.AnnouncedDims, in.AnnouncedDims + 3, dims);
  else if (!nvi::ResolveSamplingDimensions(inputObject, name, assoc, this->SamplingDimensions, dims, problem))
  {
    vtkErrorMacro("Neural Compress: cannot resample the " << inputObject->GetClassName() << " input: " << problem
                                                          << ". The output is empty.");
    return false;
  }
  if (!in.Resampler.Resample(inputObject, name, assoc, dims, input.Resampled, outsideCount, problem))
  {
    vtkErrorMacro("Neural Compress: cannot resample the " << inputObject->GetClassName() << " input: " << problem
                                                          << ". The output is empty.");
    return false;
  }
  input.Image = input.Resampled;
  input.Array = input.Resampled->GetPointData()->GetArray(name);
  input.Association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  input.Outside = std::make_shared<std::vector<uint8_t>>(size_t(input.Array->GetNumberOfTuples()), uint8_t(0));
  for (vtkIdType i = 0; i < input.Array->GetNumberOfTuples(); ++i)
    (*input.Outside)[size_t(i)] = std::isnan(input.Array->GetComponent(i, 0)) ? 1 : 0;
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::IsCurrentTraining(vtkDataArray* array, const std::string& canonical, double time) const
{
  const vtkInternals& in = *this->Internals;
  return in.Current && in.KeyArray == array && in.KeyArrayMTime == array->GetMTime() &&
    in.KeySettings == canonical && in.Current->Time == time;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::DescribeField(const nvi::SelectedInput& input, nvi::FieldInfo& field)
{
  vtkDataArray* array = input.Array;
  vtkImageData* image = input.Image;
  field.Name = array->GetName() ? array->GetName() : "Scalars";
  field.Cells = input.Association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  field.VtkType = array->GetDataType();
  int ext[6];
  image->GetExtent(ext);
  field.Geometry =
    nvi::ComputeGeometry(ext, image->GetOrigin(), image->GetSpacing(), field.Cells, this->OutputResolution);
  std::copy(image->GetDirectionMatrix()->GetData(), image->GetDirectionMatrix()->GetData() + 9, field.Direction);
  std::copy(ext, ext + 6, field.InputExtent);
  std::copy(image->GetOrigin(), image->GetOrigin() + 3, field.InputOrigin);
  std::copy(image->GetSpacing(), image->GetSpacing() + 3, field.InputSpacing);
  field.Outside = input.Outside;
  const int64_t dims[3] = { field.Geometry.SourceDims[0], field.Geometry.SourceDims[1],
    field.Geometry.SourceDims[2] };
  // A decoded output the machine cannot hold is refused before any training (the estimate and the limit).
  nvi::CheckDecodedOutputMemory(field, this->OutputMode);
  if (dims[0] * dims[1] * dims[2] <= 0)
  {
    vtkErrorMacro("Neural Compress: the input image has no " << (field.Cells ? "cells" : "points")
                                                             << "; nothing to train on.");
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ReadField(const nvi::SelectedInput& input, nvi::FieldInfo& field, nv::TrainingData& data)
{
  vtkInternals& in = *this->Internals;
  vtkDataArray* array = input.Array;
  const int64_t dims[3] = { field.Geometry.SourceDims[0], field.Geometry.SourceDims[1],
    field.Geometry.SourceDims[2] };
  std::string problem;
  if (!nvi::MakeSourceField(array, this->VectorMode, this->VectorComponent, dims, data.Field, problem))
  {
    vtkErrorMacro("Neural Compress: cannot use array '" << field.Name << "': " << problem << ".");
    return false;
  }
  field.Description = data.Field.Description;
  if (input.Outside)
  {
    // The source's own samples measure the result; its own array's bytes give the compression ratio.
    field.Samples = in.Resampler.Samples(this->VectorMode, this->VectorComponent);
    data.Field.RawBytes = field.Samples->SourceBytes;
    field.Description = field.Description.empty() ? in.Resampler.Description()
                                                  : field.Description + "; " + in.Resampler.Description();
  }
  // The run may read the array in place from another thread: keep it alive.
  array->Register(this);
  data.Owner = std::shared_ptr<void>(array, [](void* a) { static_cast<vtkDataArray*>(a)->UnRegister(nullptr); });
  field.Stats = nv::computeStats(data.Field.View);
  if (field.Stats.valid == 0)
  {
    vtkErrorMacro("Neural Compress: all " << field.Stats.invalid << " values of '" << field.Name
                                          << "' are NaN or Inf; nothing to train on.");
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ProbeTrainingPoints(vtkDataObject* inputObject, nvi::FieldInfo& field, nv::TrainingData& data)
{
  vtkInternals& in = *this->Internals;
  // Probe sampling: the training targets are a bank of points probed inside the source's cells (once per
  // input), normalised like the field; the range covers both.
  const int64_t count = this->ProbePoints > 0 ? this->ProbePoints : int64_t(1) << 20;
  std::string problem;
  std::shared_ptr<const nvi::ProbedBank> bank =
    in.Resampler.Probe(count, uint64_t(this->Seed), this->VectorMode, this->VectorComponent, problem);
  if (!bank)
  {
    vtkErrorMacro("Neural Compress: cannot probe the " << inputObject->GetClassName() << " input: " << problem
                                                       << ". The output is empty.");
    return false;
  }
  for (double v : bank->Values)
  {
    field.Stats.min = std::min(field.Stats.min, v);
    field.Stats.max = std::max(field.Stats.max, v);
  }
  const nv::ValueRange range(field.Stats.min, field.Stats.max); // safe when max - min overflows
  data.BankXyz = bank->Xyz;
  data.BankValues.resize(bank->Values.size());
  for (size_t i = 0; i < bank->Values.size(); ++i)
    data.BankValues[i] = static_cast<float>(range.fraction(bank->Values[i]));
  std::ostringstream d;
  d << "; Probe: " << bank->Values.size() << " of " << bank->Probed << " random points inside the domain ("
    << std::fixed << std::setprecision(2) << bank->Seconds << " s)";
  field.Description += d.str();
  return true;
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::StartJobIfChanged(vtkDataArray* array, const nvi::FieldInfo& field,
  std::shared_ptr<nv::TrainingData> data, const nvi::Settings& settings, const std::string& canonical, double time)
{
  vtkInternals& in = *this->Internals;
  in.Key = nvi::TrainingKey(data->Field.View, field, settings);
  in.KeyArray = array;
  in.KeyArrayMTime = array->GetMTime();
  in.KeySettings = canonical;
  if (in.Current && in.Current->Key == in.Key && in.Current->Time == time)
  {
    return;
  }
  if (field.Outside)
  {
    vtkDebugMacro("Neural Compress: " << in.Resampler.Description());
  }
  const int64_t outsideCount =
    field.Outside ? std::count(field.Outside->begin(), field.Outside->end(), uint8_t(1)) : int64_t(0);
  if (field.Stats.invalid > outsideCount)
  {
    vtkWarningMacro("Neural Compress: " << field.Stats.invalid - outsideCount << " of " << data->Field.View.count()
                                        << " values of '" << field.Name
                                        << "' are NaN or Inf; they are excluded from training "
                                           "and decode to finite values.");
  }
  in.Retire();
  this->StartJob(field, data, settings, in.Key, time);
}
