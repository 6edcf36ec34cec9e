#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralNetworkArray.h"

#include "Core/Error.h"
#include "Core/Serialization.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"
#include "vtkTable.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

namespace nvi = vtkNeuralCompressInternals;

vtkStandardNewMacro(vtkNeuralCompress);

namespace
{

bool IsCellAssociation(vtkInformation* arrayInfo)
{
  return arrayInfo && arrayInfo->Has(vtkDataObject::FIELD_ASSOCIATION()) &&
    arrayInfo->Get(vtkDataObject::FIELD_ASSOCIATION()) == vtkDataObject::FIELD_ASSOCIATION_CELLS;
}

template <typename ArrayT, typename ValueT>
void AddFieldValue(vtkFieldData* fd, const char* name, ValueT value)
{
  vtkNew<ArrayT> a;
  a->SetName(name);
  a->SetNumberOfTuples(1);
  a->SetValue(0, value);
  fd->AddArray(a);
}

void InitializeLog(vtkTable* log)
{
  log->Initialize();
  for (const char* name : { "Step", "Loss", "LearningRate", "ElapsedSeconds", "PSNR" })
  {
    vtkNew<vtkDoubleArray> column;
    column->SetName(name);
    log->AddColumn(column);
  }
}

std::string FormatBytes(double bytes)
{
  std::ostringstream s;
  s.precision(3);
  if (bytes >= 1024.0 * 1024.0)
  {
    s << bytes / (1024.0 * 1024.0) << " MiB";
  }
  else if (bytes >= 1024.0)
  {
    s << bytes / 1024.0 << " KiB";
  }
  else
  {
    s << bytes << " B";
  }
  return s.str();
}

} // namespace

//------------------------------------------------------------------------------
vtkNeuralCompress::vtkNeuralCompress()
{
  this->SetNumberOfInputPorts(1);
  this->SetNumberOfOutputPorts(2);
  this->SetInputArrayToProcess(0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS,
    vtkDataSetAttributes::SCALARS);
}

vtkNeuralCompress::~vtkNeuralCompress() = default;

//------------------------------------------------------------------------------
int vtkNeuralCompress::FillInputPortInformation(int, vtkInformation* info)
{
  // Any dataset is accepted so that unsupported types get a clear message instead of a
  // pipeline type error.
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataSet");
  return 1;
}

int vtkNeuralCompress::FillOutputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkImageData" : "vtkTable");
  return 1;
}

int vtkNeuralCompress::RequestDataObject(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkDataObjectAlgorithm::SetOutputDataObject(
    VTK_IMAGE_DATA, outputVector->GetInformationObject(0), /*exact=*/true);
  vtkDataObjectAlgorithm::SetOutputDataObject(
    VTK_TABLE, outputVector->GetInformationObject(1), /*exact=*/true);
  return 1;
}

//------------------------------------------------------------------------------
int vtkNeuralCompress::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkDataObject* input = inInfo ? inInfo->Get(vtkDataObject::DATA_OBJECT()) : nullptr;
  if (!vtkImageData::SafeDownCast(input) ||
    !inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    outInfo->Remove(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    return 1;
  }
  int ext[6];
  double origin[3] = { 0, 0, 0 }, spacing[3] = { 1, 1, 1 };
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext);
  if (inInfo->Has(vtkDataObject::ORIGIN()))
  {
    inInfo->Get(vtkDataObject::ORIGIN(), origin);
  }
  if (inInfo->Has(vtkDataObject::SPACING()))
  {
    inInfo->Get(vtkDataObject::SPACING(), spacing);
  }
  const nvi::OutputGeometry g = nvi::ComputeGeometry(
    ext, origin, spacing, IsCellAssociation(this->GetInputArrayInformation(0)), this->OutputResolution);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), g.Extent, 6);
  outInfo->Set(vtkDataObject::ORIGIN(), g.Origin, 3);
  outInfo->Set(vtkDataObject::SPACING(), g.Spacing, 3);
  if (inInfo->Has(vtkDataObject::DIRECTION()))
  {
    outInfo->CopyEntry(inInfo, vtkDataObject::DIRECTION());
  }
  return 1;
}

int vtkNeuralCompress::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // Training needs the whole field.
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo && inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    int ext[6];
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext);
    inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), ext, 6);
  }
  return 1;
}

//------------------------------------------------------------------------------
int vtkNeuralCompress::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkDataObject* inputObject = vtkDataObject::GetData(inputVector[0], 0);
  vtkImageData* output = vtkImageData::GetData(outputVector, 0);
  vtkTable* log = vtkTable::GetData(outputVector, 1);
  if (!output || !log)
  {
    vtkErrorMacro("Neural Compress: missing output objects.");
    return 0;
  }
  output->Initialize();
  this->Session.reset(); // the previous output's network
  InitializeLog(log);

  if (!this->Execute(inputObject, inputVector, output, log))
  {
    // A defined result: no arrays, no network. For an image input the output keeps the promised
    // (input) geometry, so the pipeline does not execute again (and repeat the error) on every
    // update.
    output->Initialize();
    InitializeLog(log);
    vtkInformation* outInfo = outputVector->GetInformationObject(0);
    if (outInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    {
      int ext[6];
      double origin[3], spacing[3];
      outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), ext);
      outInfo->Get(vtkDataObject::ORIGIN(), origin);
      outInfo->Get(vtkDataObject::SPACING(), spacing);
      output->SetExtent(ext);
      output->SetOrigin(origin);
      output->SetSpacing(spacing);
    }
  }
  return 1;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::Execute(vtkDataObject* inputObject, vtkInformationVector** inputVector,
  vtkImageData* output, vtkTable* log)
{
  vtkImageData* input = vtkImageData::SafeDownCast(inputObject);
  if (!input)
  {
    vtkErrorMacro("Neural Compress supports vtkImageData input only; "
      << (inputObject ? inputObject->GetClassName() : "no") << " input (unstructured grids, "
      << "polydata, other datasets) arrives in a later version. The output is empty.");
    return false;
  }
  if (input->GetNumberOfPoints() == 0)
  {
    vtkErrorMacro("Neural Compress: the input image has an empty extent; nothing to train on. "
                  "The output is empty.");
    return false;
  }

  int association = -1;
  vtkDataArray* array = this->GetInputArrayToProcess(0, inputVector, association);
  if (!array)
  {
    vtkErrorMacro("Neural Compress: no input array. Select a numeric point or cell array of the "
                  "image (SelectInputScalars). The output is empty.");
    return false;
  }
  if (association != vtkDataObject::FIELD_ASSOCIATION_POINTS &&
    association != vtkDataObject::FIELD_ASSOCIATION_CELLS)
  {
    vtkErrorMacro("Neural Compress: array '" << (array->GetName() ? array->GetName() : "")
                                             << "' is neither a point nor a cell array. "
                                                "The output is empty.");
    return false;
  }

  return this->Compress(input, array, association, output, log);
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::Compress(
  vtkImageData* input, vtkDataArray* array, int association, vtkImageData* output, vtkTable* log)
{
  const bool cells = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  const std::string name = array->GetName() ? array->GetName() : "Scalars";
  int ext[6];
  input->GetExtent(ext);
  const nvi::OutputGeometry g =
    nvi::ComputeGeometry(ext, input->GetOrigin(), input->GetSpacing(), cells, this->OutputResolution);
  const int64_t dims[3] = { g.SourceDims[0], g.SourceDims[1], g.SourceDims[2] };
  if (dims[0] * dims[1] * dims[2] <= 0)
  {
    vtkErrorMacro("Neural Compress: the input image has no " << (cells ? "cells" : "points")
                                                             << "; nothing to train on.");
    return false;
  }

  nvi::SourceField field;
  std::string problem;
  if (!nvi::MakeSourceField(array, this->VectorMode, this->VectorComponent, dims, field, problem))
  {
    vtkErrorMacro("Neural Compress: cannot use array '" << name << "': " << problem << ".");
    return false;
  }

  try
  {
    const nv::VolumeStats stats = nv::computeStats(field.View);
    if (stats.valid == 0)
    {
      vtkErrorMacro("Neural Compress: all " << stats.invalid << " values of '" << name
                                            << "' are NaN or Inf; nothing to train on.");
      return false;
    }
    if (stats.invalid > 0)
    {
      vtkWarningMacro("Neural Compress: " << stats.invalid << " of " << field.View.count()
                                          << " values of '" << name
                                          << "' are NaN or Inf; they are excluded from training "
                                             "and decode to finite values.");
    }
    field.View.valueMin = stats.min;
    field.View.valueMax = stats.max;
    const bool constant = !(stats.max > stats.min);

    // Model configuration.
    const nv::Precision precision =
      this->StoragePrecision == FLOAT16 ? nv::Precision::Float16 : nv::Precision::Float32;
    nv::ModelConfig config;
    config.encoding.levels = this->Levels;
    config.encoding.featuresPerLevel = this->FeaturesPerLevel;
    config.encoding.baseResolution = this->BaseResolution;
    config.encoding.perLevelScale = 0.0;
    // Default finest level: twice the largest dimension (never below the base resolution).
    config.encoding.finestResolution = this->FinestResolution > 0
      ? this->FinestResolution
      : static_cast<int>(std::max<int64_t>(
          2 * std::max({ dims[0], dims[1], dims[2] }), this->BaseResolution));
    config.network.width = this->NetworkWidth;
    config.network.hiddenLayers = this->HiddenLayers;
    config.encoding.log2TableSize = this->Log2TableSize > 0 ? this->Log2TableSize : 10;
    nv::validate(config);
    if (this->Log2TableSize <= 0)
    {
      config.encoding.log2TableSize = nv::chooseLog2TableSize(
        config, field.RawBytes, this->TargetCompressionRatio, precision);
    }

    nv::TrainConfig train;
    train.batchSize = this->BatchSize;
    train.seed = static_cast<uint64_t>(this->Seed);
    train.loss = this->Loss == LOSS_L2 ? nv::LossType::L2 : nv::LossType::L1;
    train.optimizer.learningRate = this->LearningRate;
    train.optimizer.stepDecay = this->LearningRateSchedule == STEP_DECAY;
    train.threads = this->Threads;
    train.strategy = static_cast<nv::TrainingStrategy>(this->TrainingStrategy);
    nv::validate(train);

    std::string deviceNote;
    const nv::Device device = nv::resolveDevice(this->Device == DEVICE_CPU ? nv::Device::Cpu
        : this->Device == DEVICE_CUDA                                      ? nv::Device::Cuda
                                                                           : nv::Device::Auto,
      &deviceNote);

    nv::Model model(config);
    model.initialize(train.seed);
    nv::SourceInfo& src = model.source;
    for (int d = 0; d < 3; ++d)
    {
      src.dims[d] = dims[d];
      src.spacing[d] = input->GetSpacing()[d];
      // The trained field spans the source samples: the points, or the cell centres.
      const double first = input->GetOrigin()[d] + ext[2 * d] * input->GetSpacing()[d] +
        (cells && ext[2 * d + 1] > ext[2 * d] ? 0.5 * input->GetSpacing()[d] : 0.0);
      src.origin[d] = first;
      src.bounds[2 * d] = first;
      src.bounds[2 * d + 1] = first + (dims[d] - 1) * input->GetSpacing()[d];
    }
    src.valueMin = stats.min;
    src.valueMax = stats.max;
    src.arrayName = name;
    src.association = cells ? 1 : 0;
    src.rawBytes = field.RawBytes;

    nv::SessionOptions sessionOptions;
    sessionOptions.threads = this->Threads;
    // Kept by the filter while its output holds this network: renderers of this process use it (the
    // registry of vtkNeuralNetworkArray) instead of loading the bytes again.
    std::shared_ptr<nv::NetworkSession> session = nv::NetworkSession::create(device, model, sessionOptions);

    // Training.
    nvi::TrainingResult result;
    if (constant)
    {
      vtkWarningMacro("Neural Compress: '" << name << "' is constant (" << stats.min
                                           << "); it is represented exactly, training skipped.");
    }
    else if (this->TrainingSteps > 0)
    {
      nvi::PsnrProbe probe(field.View, train.seed, 65536);
      nvi::TrainingRequest request;
      request.MaxSteps = this->TrainingSteps;
      request.TimeBudget = this->TimeBudget;
      request.PsnrInterval = this->PSNRInterval;
      request.ShouldAbort = [this]() { return this->GetAbortExecute() != 0; };
      request.Progress = [this](double f) { this->UpdateProgress(0.95 * f); };
      result = nvi::Train(*session, field.View, train, request, &probe);
      session->syncModel();
      model.params() = session->model().params();
    }
    // The output is decoded from the network as it is stored.
    model.quantize(precision);
    session->setModel(model);

    // Decode the output grid.
    const int64_t n[3] = { g.DecodedDims[0], g.DecodedDims[1], g.DecodedDims[2] };
    vtkNew<vtkFloatArray> decoded;
    decoded->SetName(name.c_str());
    decoded->SetNumberOfTuples(n[0] * n[1] * n[2]);
    float* out = decoded->GetPointer(0);
    if (!cells || g.OnSourceGrid)
    {
      nv::decodeGridValues(*session, n[0], n[1], n[2], 0, n[2], out);
    }
    else
    {
      // Cell centres of the resampled output in the source's normalised coordinates.
      std::vector<float> xyz(static_cast<size_t>(n[0] * n[1] * n[2]) * 3);
      size_t k = 0;
      for (int64_t z = 0; z < n[2]; ++z)
        for (int64_t y = 0; y < n[1]; ++y)
          for (int64_t x = 0; x < n[0]; ++x)
          {
            const int64_t ijk[3] = { x, y, z };
            for (int d = 0; d < 3; ++d)
            {
              const double world = g.Origin[d] + (ijk[d] + 0.5) * g.Spacing[d];
              const double span = src.bounds[2 * d + 1] - src.bounds[2 * d];
              const double u = span > 0 ? (world - src.bounds[2 * d]) / span : 0.5;
              xyz[k++] = static_cast<float>(std::min(1.0, std::max(0.0, u)));
            }
          }
      session->inferPoints(xyz.data(), n[0] * n[1] * n[2], out, nv::Memory::Host);
      for (int64_t i = 0; i < n[0] * n[1] * n[2]; ++i)
      {
        out[i] = static_cast<float>(model.denormalize(out[i]));
      }
    }
    const nv::ErrorStats error = g.OnSourceGrid
      ? nv::compareDecoded(out, field.View, stats.min, stats.max, this->Threads)
      : nv::compareToSource(*session, field.View);
    this->UpdateProgress(0.98);

    model.stats.steps = result.Steps;
    model.stats.seconds = result.Seconds;
    model.stats.finalLoss = result.FinalLoss;
    model.stats.psnr = error.psnr;
    model.stats.maxError = error.maxAbsError;
    model.stats.invalidSamples = stats.invalid;
    model.stats.device = nv::deviceName(device);
    const std::vector<uint8_t> bytes = nv::serialize(model);
    const int64_t modelBytes = model.parameterBytes();
    const double ratio = static_cast<double>(field.RawBytes) / static_cast<double>(modelBytes);
    if (this->Log2TableSize <= 0 && ratio < this->TargetCompressionRatio)
    {
      vtkWarningMacro("Neural Compress: the target compression ratio "
        << this->TargetCompressionRatio << ":1 is out of reach for this field and network "
        << "(the smallest hash table gives " << ratio << ":1); use fewer Levels, "
        << "FeaturesPerLevel, a narrower network or Float16 storage.");
    }

    // Output image.
    int outExtent[6];
    std::copy(g.Extent, g.Extent + 6, outExtent);
    output->SetExtent(outExtent);
    output->SetOrigin(g.Origin);
    output->SetSpacing(g.Spacing);
    output->SetDirectionMatrix(input->GetDirectionMatrix());
    if (cells)
    {
      output->GetCellData()->SetScalars(decoded);
    }
    else
    {
      output->GetPointData()->SetScalars(decoded);
    }
    vtkFieldData* fd = output->GetFieldData();
    vtkNeuralNetworkArray::Write(fd, bytes, session);
    this->Session = session;
    AddFieldValue<vtkDoubleArray>(fd, "NeuralTrainingSeconds", result.Seconds);
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralSteps", result.Steps);
    AddFieldValue<vtkDoubleArray>(fd, "NeuralPSNR", error.psnr);
    AddFieldValue<vtkDoubleArray>(fd, "NeuralMaxError", error.maxAbsError);
    AddFieldValue<vtkDoubleArray>(fd, "NeuralCompressionRatio", ratio);
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralModelBytes", modelBytes);
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralInvalidSamples", stats.invalid);
    AddFieldValue<vtkTypeInt64Array>(fd, "NeuralGpuMemoryBytes", result.DeviceMemoryBytes);
    vtkNew<vtkStringArray> deviceArray;
    deviceArray->SetName("NeuralDevice");
    deviceArray->InsertNextValue(nv::deviceName(device));
    fd->AddArray(deviceArray);

    // Training log.
    const vtkIdType rows = static_cast<vtkIdType>(result.Log.size());
    log->SetNumberOfRows(rows);
    for (vtkIdType r = 0; r < rows; ++r)
    {
      const nvi::LogRow& row = result.Log[r];
      const double psnr = r == rows - 1 ? error.psnr : row.PSNR;
      const double values[5] = { static_cast<double>(row.Step), row.Loss, row.LearningRate,
        row.ElapsedSeconds, psnr };
      for (int c = 0; c < 5; ++c)
      {
        vtkDoubleArray::SafeDownCast(log->GetColumn(c))->SetValue(r, values[c]);
      }
    }

    // One-line summary (informative, not a warning).
    std::ostringstream summary;
    summary.precision(4);
    summary << "Neural Compress: '" << name << "' (" << (cells ? "cell" : "point") << ", "
            << array->GetDataTypeAsString();
    if (!field.Description.empty())
    {
      summary << ", " << field.Description;
    }
    summary << ", " << dims[0] << "x" << dims[1] << "x" << dims[2] << "): " << result.Steps
            << " steps in " << result.Seconds << " s on " << nv::deviceName(device);
    if (result.Aborted)
    {
      summary << " (aborted)";
    }
    else if (result.TimedOut)
    {
      summary << " (time budget reached)";
    }
    summary << "; PSNR " << error.psnr << " dB, max error " << error.maxAbsError << "; model "
            << FormatBytes(static_cast<double>(modelBytes)) << " (2^"
            << config.encoding.log2TableSize << " table, "
            << (precision == nv::Precision::Float16 ? "fp16" : "fp32") << "), ratio " << ratio
            << ":1 (target " << this->TargetCompressionRatio << ")";
    if (!deviceNote.empty())
    {
      summary << "; " << deviceNote;
    }
    summary << "\n";
    vtkOutputWindowDisplayText(summary.str().c_str());
    this->UpdateProgress(1.0);
    return true;
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

//------------------------------------------------------------------------------
void vtkNeuralCompress::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "VectorMode: " << this->VectorMode << "\n"
     << indent << "VectorComponent: " << this->VectorComponent << "\n"
     << indent << "TrainingSteps: " << this->TrainingSteps << "\n"
     << indent << "TimeBudget: " << this->TimeBudget << "\n"
     << indent << "BatchSize: " << this->BatchSize << "\n"
     << indent << "LearningRate: " << this->LearningRate << "\n"
     << indent << "Seed: " << this->Seed << "\n"
     << indent << "Loss: " << this->Loss << "\n"
     << indent << "LearningRateSchedule: " << this->LearningRateSchedule << "\n"
     << indent << "TargetCompressionRatio: " << this->TargetCompressionRatio << "\n"
     << indent << "Levels: " << this->Levels << "\n"
     << indent << "FeaturesPerLevel: " << this->FeaturesPerLevel << "\n"
     << indent << "Log2TableSize: " << this->Log2TableSize << "\n"
     << indent << "BaseResolution: " << this->BaseResolution << "\n"
     << indent << "FinestResolution: " << this->FinestResolution << "\n"
     << indent << "NetworkWidth: " << this->NetworkWidth << "\n"
     << indent << "HiddenLayers: " << this->HiddenLayers << "\n"
     << indent << "StoragePrecision: " << this->StoragePrecision << "\n"
     << indent << "Device: " << this->Device << "\n"
     << indent << "Threads: " << this->Threads << "\n"
     << indent << "TrainingStrategy: " << this->TrainingStrategy << "\n"
     << indent << "OutputResolution: " << this->OutputResolution[0] << " "
     << this->OutputResolution[1] << " " << this->OutputResolution[2] << "\n"
     << indent << "PSNRInterval: " << this->PSNRInterval << "\n";
}
