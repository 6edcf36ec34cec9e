// vtkNeuralCompress on a sparse OpenVDB grid (the OpenVDB reader's active voxels; vtkNeuralCompressSparse.h): the
// network is trained from a bank of the active voxels and background samples, without a dense grid; the output
// image covers the grid's box and its figures are measured at the bank's samples.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressSparse.h"
#include "vtkNeuralCompressState.h"

#include "Core/Error.h"
#include "Core/Serialization.h"
#include "Core/ValueRange.h"

#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkInformation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace nvi = vtkNeuralCompressInternals;

namespace
{
/// The value range of the bank (its NaN and Inf values counted as invalid, left out of the range).
nv::VolumeStats StatsOfBank(const std::vector<double>& values)
{
  nv::VolumeStats stats;
  stats.min = std::numeric_limits<double>::infinity();
  stats.max = -std::numeric_limits<double>::infinity();
  for (double v : values)
  {
    const bool ok = std::isfinite(v);
    stats.valid += ok ? 1 : 0;
    stats.invalid += ok ? 0 : 1;
    stats.min = ok ? std::min(stats.min, v) : stats.min;
    stats.max = ok ? std::max(stats.max, v) : stats.max;
  }
  return stats;
}

/// The training data of a sparse grid: no dense field (the view only carries the box's dimensions and the value
/// range, its data stays null), the bank's positions (moved out of `bank`) and its values normalised to the range.
std::shared_ptr<nvi::TrainingData> TrainingDataOfBank(
  const nvi::SparseVoxels& voxels, nvi::SparseBank& bank, const nv::VolumeStats& stats)
{
  auto data = std::make_shared<nvi::TrainingData>();
  data->Field.View.data = nullptr;
  data->Field.View.type = nv::ScalarType::Float32;
  for (int a = 0; a < 3; ++a)
    data->Field.View.dims[a] = voxels.Dims[a];
  data->Field.View.valueMin = stats.min;
  data->Field.View.valueMax = stats.max;
  data->Field.RawBytes = bank.Samples->SourceBytes;
  const nv::ValueRange range(stats.min, stats.max);
  data->BankXyz = std::move(bank.Xyz);
  data->BankValues.resize(bank.Values.size());
  for (size_t i = 0; i < bank.Values.size(); ++i)
    data->BankValues[i] = std::isfinite(bank.Values[i])
      ? static_cast<float>(range.fraction(bank.Values[i]))
      : std::numeric_limits<float>::quiet_NaN();
  return data;
}

/// What the training of a sparse grid says of its input (the field's description).
std::string SparseDescription(const nvi::SparseVoxels& voxels, const nvi::SparseBank& bank)
{
  std::ostringstream d;
  d << "sparse OpenVDB grid, " << bank.Active << " active of " << bank.Active + bank.Inactive
    << " voxels; trained on them and " << bank.Background << " inactive voxels at the background "
    << voxels.Background;
  return d.str();
}

/// The key: the settings, the box's geometry, and the bank (values and positions) in place of a dense field.
uint64_t SparseTrainingKey(const std::vector<double>& bankValues, const std::vector<float>& bankXyz,
  const nvi::FieldInfo& field, const nvi::Settings& settings)
{
  nv::VolumeView keyView;
  keyView.data = bankValues.data();
  keyView.type = nv::ScalarType::Float64;
  keyView.dims[0] = static_cast<int64_t>(bankValues.size());
  keyView.dims[1] = keyView.dims[2] = 1;
  const uint64_t positions =
    nv::crc32(reinterpret_cast<const uint8_t*>(bankXyz.data()), bankXyz.size() * sizeof(float));
  return nvi::TrainingKey(keyView, field, settings) ^ (positions * 0x9E3779B97F4A7C15ull);
}

/// What decides the training of a sparse grid (a new job starts when any of it differs).
nvi::InputIdentity SparseIdentity(
  const nvi::SparseVoxels& voxels, const std::string& arrayName, const nvi::Settings& settings, double time)
{
  nvi::InputIdentity identity;
  identity.Object = voxels.Values;
  identity.MTime = voxels.Values->GetMTime();
  identity.Array = arrayName;
  identity.Association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  identity.Settings = settings.Canonical();
  identity.Time = time;
  return identity;
}
} // namespace

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ReadSparseInput(vtkDataObject* inputObject, nvi::SparseVoxels& voxels, std::string& arrayName)
{
  vtkInformation* ai = this->GetInputArrayInformation(0);
  const char* name = ai && ai->Has(vtkDataObject::FIELD_NAME()) ? ai->Get(vtkDataObject::FIELD_NAME()) : nullptr;
  const int assoc = ai && ai->Has(vtkDataObject::FIELD_ASSOCIATION()) ? ai->Get(vtkDataObject::FIELD_ASSOCIATION()) : -1;
  arrayName = name && *name ? name : nvi::SparseScalarsName(inputObject);
  if (arrayName.empty() || (assoc >= 0 && assoc != vtkDataObject::FIELD_ASSOCIATION_POINTS))
  {
    vtkErrorMacro("Neural Compress: select the sparse grid's point array (its values). The output is empty.");
    return false;
  }
  std::string problem;
  if (!nvi::ReadSparseVoxels(inputObject, arrayName, voxels, problem))
  {
    vtkErrorMacro("Neural Compress: cannot use the sparse OpenVDB grid: " << problem << ". The output is empty.");
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
nvi::FieldInfo vtkNeuralCompress::SparseFieldGeometry(const nvi::SparseVoxels& voxels, const std::string& arrayName)
{
  nvi::FieldInfo field;
  field.Name = arrayName;
  field.Cells = false;
  field.VtkType = voxels.Values->GetDataType();
  const int ext[6] = { 0, voxels.Dims[0] - 1, 0, voxels.Dims[1] - 1, 0, voxels.Dims[2] - 1 };
  field.Geometry = nvi::ComputeGeometry(ext, voxels.Origin, voxels.Spacing, false, this->OutputResolution,
    this->FinestResolution, this->BaseResolution);
  this->ReportOutputCap(field.Geometry);
  std::copy(voxels.Direction, voxels.Direction + 9, field.Direction);
  std::copy(ext, ext + 6, field.InputExtent);
  std::copy(voxels.Origin, voxels.Origin + 3, field.InputOrigin);
  std::copy(voxels.Spacing, voxels.Spacing + 3, field.InputSpacing);
  return field;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ExecuteSparse(
  vtkDataObject* inputObject, vtkImageData* output, vtkTable* log, vtkTable* metrics, double time)
{
  vtkInternals& in = *this->Internals;
  nvi::SparseVoxels voxels;
  std::string arrayName;
  if (!this->ReadSparseInput(inputObject, voxels, arrayName))
    return false;
  try
  {
    nvi::Settings settings = this->CurrentSettings();
    settings.Sampling = settings.ProbePoints = 0; // the bank is the grid's own voxels
    const nvi::InputIdentity identity = SparseIdentity(voxels, arrayName, settings, time);
    if (this->IsCurrentTraining(identity))
    {
      return this->EmitOutputs(output, log, metrics); // a live refresh or a control: same training
    }

    nvi::FieldInfo field = this->SparseFieldGeometry(voxels, arrayName);
    nvi::SparseBank bank;
    std::string problem;
    if (!nvi::MakeSparseBank(voxels, this->VectorMode, this->VectorComponent, uint64_t(this->Seed), bank, problem))
    {
      vtkErrorMacro("Neural Compress: cannot use the sparse OpenVDB grid: " << problem << ". The output is empty.");
      return false;
    }
    field.Samples = bank.Samples;
    field.Occupancy = std::make_shared<const std::vector<uint32_t>>(std::move(bank.Occupancy));
    field.Background = voxels.Background;
    const nv::VolumeStats stats = StatsOfBank(bank.Values);
    if (stats.valid == 0)
    {
      vtkErrorMacro("Neural Compress: all " << stats.invalid << " values of '" << field.Name
                                            << "' are NaN or Inf; nothing to train on.");
      return false;
    }
    field.Stats = stats; // a range wider than the largest double is normalised on halves (Core/ValueRange.h)
    std::shared_ptr<nvi::TrainingData> data = TrainingDataOfBank(voxels, bank, stats);
    field.Description = SparseDescription(voxels, bank);
    data->Field.Description = field.Description;

    in.Key = SparseTrainingKey(bank.Values, data->BankXyz, field, settings);
    in.KeyIdentity = identity;
    if (!in.Current || in.Current->Key != in.Key || in.Current->Time != time)
    {
      if (stats.invalid > 0)
      {
        vtkWarningMacro("Neural Compress: " << stats.invalid << " of " << bank.Active << " active values of '"
                                            << field.Name << "' are NaN or Inf; they are excluded from training.");
      }
      in.Retire();
      this->StartJob(field, data, settings, in.Key, time);
    }
    return this->EmitOutputs(output, log, metrics);
  }
  catch (const nv::Error& e)
  {
    vtkErrorMacro("Neural Compress: " << e.what());
  }
  catch (const std::exception& e)
  {
    vtkErrorMacro("Neural Compress: unexpected failure: " << e.what());
  }
  return false;
}
