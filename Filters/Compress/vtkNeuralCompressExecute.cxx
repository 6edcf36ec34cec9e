// vtkNeuralCompress::Execute and its steps: the input and its selected array (an image, or a dataset resampled onto
// one), the field the network is trained on, and the job that trains it when the input or the settings changed.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressDecode.h"
#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressPreparation.h"
#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressSparse.h"
#include "vtkNeuralCompressState.h"
#include "vtkNeuralOutOfCoreInput.h"

#include "Core/EngineWarnings.h"
#include "Core/Error.h"
#include "Core/ResourceEstimate.h"
#include "Core/ValueRange.h"

#include "vtkCompositeDataSet.h"
#include "vtkDataSetAttributes.h"
#include "vtkCellData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkFieldData.h"
#include "vtkMatrix3x3.h"
#include "vtkNew.h"
#include "vtkStringArray.h"
#include "vtkOutputWindow.h"
#include "vtkPointData.h"
#include "vtkSmartPointer.h"

#include <algorithm>
#include <chrono>
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
  /// A resampling coarsened to fit the TimeBudget: the dimensions announced, which the output keeps (0: none).
  int DecodedDims[3] = { 0, 0, 0 };
};
} // namespace vtkNeuralCompressInternals

/// The filter's particle properties (particle inputs; ignored by the others).
nvi::ParticleSettings ParticleSettingsOf(vtkNeuralCompress* filter)
{
  nvi::ParticleSettings s;
  s.Field = filter->GetParticleField();
  s.Kernel = filter->GetParticleKernel();
  s.Radius = filter->GetParticleRadius();
  s.RadiusArray = filter->GetParticleRadiusArray() ? filter->GetParticleRadiusArray() : "";
  s.VectorMode = filter->GetVectorMode();
  s.VectorComponent = filter->GetVectorComponent();
  return s;
}

namespace
{
/// Automatic sampling dimensions under a TimeBudget: resampling takes at most this share of it, probing at most
/// kProbeBudgetShare (both measured on the input).
constexpr double kResampleBudgetShare = 0.25;
constexpr double kProbeBudgetShare = 0.2;
}

// Messages of the steps that may run in a preparation's thread: queued there, printed by the filter's thread.
#define nvReport(level, x)                                                                                        \
  do                                                                                                              \
  {                                                                                                               \
    std::ostringstream nvReportText;                                                                              \
    nvReportText << x;                                                                                            \
    this->Report(nvi::QueuedMessage::level, nvReportText.str());                                                  \
  } while (0)

//------------------------------------------------------------------------------
void vtkNeuralCompress::Report(int level, const std::string& text)
{
  if (nvi::Preparation* preparation = nvi::Preparation::OfThisThread())
  {
    preparation->Queue(static_cast<nvi::QueuedMessage::Level>(level), text); // printed by the filter's thread
  }
  else if (level == nvi::QueuedMessage::Error)
  {
    vtkErrorMacro(<< text);
  }
  else if (level == nvi::QueuedMessage::Warning)
  {
    vtkWarningMacro(<< text);
  }
  else
  {
    vtkOutputWindowDisplayText((text + "\n").c_str());
  }
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::Execute(vtkDataObject* inputObject, vtkInformationVector** inputVector,
  vtkImageData* output, vtkTable* log, vtkTable* metrics, double time, bool background)
{
  if (!vtkImageData::SafeDownCast(inputObject) && nvi::IsSparseVoxels(inputObject))
  {
    return this->ExecuteSparse(inputObject, output, log, metrics, time);
  }
  nvi::InputRequest request;
  if (!this->RequestInput(inputObject, inputVector, request))
  {
    return false;
  }
  nvi::Settings settings = this->CurrentSettings();
  if (request.IsImage)
    settings.Sampling = settings.ProbePoints = 0; // images are their own samples: Sampling does not apply
  else if (nvi::IsParticleSet(request.Object))
    settings.Sampling = SAMPLING_PROBE; // particles always train from the bank (their field at random points)
  if (request.OutOfCorePath.empty())
    settings.MemoryBudgetMiB = 0.0; // inputs in memory: no budget decides their training
  const nvi::InputIdentity identity = this->IdentityOf(request, settings.Canonical(), time);
  if (background)
  {
    return this->ExecuteInBackground(request, settings, identity, output, log, metrics);
  }
  vtkInternals& in = *this->Internals;
  in.Preparing.reset(); // after background runs: nothing else uses the resampler meanwhile
  try
  {
    if (this->IsCurrentTraining(identity))
    {
      return this->EmitOutputs(output, log, metrics); // a live refresh or a control: same training
    }
    const auto started = std::chrono::steady_clock::now();
    nvi::PreparedField prepared;
    if (!this->PrepareField(request, settings, prepared))
    {
      return false;
    }
    prepared.Field.PreparationSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    this->StartJobIfChanged(identity, prepared);
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
bool vtkNeuralCompress::RequestInput(
  vtkDataObject* inputObject, vtkInformationVector** inputVector, nvi::InputRequest& request)
{
  vtkImageData* image = vtkImageData::SafeDownCast(inputObject);
  request.Object = inputObject;
  request.Source = inputObject;
  request.IsImage = image != nullptr;
  request.InputMTime = inputObject ? inputObject->GetMTime() : 0;
  const nvi::ImagePiece& piece = this->Internals->Piece;
  if (image && image == piece.Training())
  {
    // MPI: this rank's piece, whose output is its part of the whole output lattice.
    std::copy(piece.Owned(), piece.Owned() + 6, request.PieceOwned);
    std::copy(piece.Whole(), piece.Whole() + 6, request.PieceWhole);
  }
  nvi::OutOfCoreRequest file;
  if (nvi::OutOfCoreRequestOf(inputObject, file))
  {
    // A file that is never loaded (vtkNeuralOutOfCoreInput.h): no array to select; the file names its field.
    request.OutOfCorePath = file.Path;
    request.OutOfCoreArray = file.Array;
    image->GetExtent(request.OutOfCoreExtent); // the whole file, or this rank's padded piece under MPI
    request.InputMTime = nvi::OutOfCoreStamp(file, request.OutOfCoreExtent);
    request.ArrayName = "file:" + file.Path + "|" + file.Array;
    request.Association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
    return true;
  }
  if (image)
  {
    if (this->Internals->GridPieceActive)
    {
      // A rank's resampled piece of a dataset or composite (vtkNeuralCompressDataSetPiece.h): its point array.
      request.Array = image->GetPointData()->GetArray(0);
      request.Association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
    }
    else
      request.Array = this->GetInputArrayToProcess(0, inputVector, request.Association);
    if (image->GetNumberOfPoints() == 0)
    {
      vtkErrorMacro("Neural Compress: the input image has an empty extent; nothing to train on. "
                    "The output is empty.");
      return false;
    }
    if (!request.Array)
    {
      vtkErrorMacro("Neural Compress: no input array. Select a numeric point or cell array of the "
                    "image (SelectInputScalars). The output is empty.");
      return false;
    }
    if (request.Association != vtkDataObject::FIELD_ASSOCIATION_POINTS &&
      request.Association != vtkDataObject::FIELD_ASSOCIATION_CELLS)
    {
      vtkErrorMacro("Neural Compress: array '" << (request.Array->GetName() ? request.Array->GetName() : "")
                                               << "' is neither a point nor a cell array. "
                                                  "The output is empty.");
      return false;
    }
    request.ArrayName = request.Array->GetName() ? request.Array->GetName() : "";
    return true;
  }
  // Not an image: resampled onto one when the field is prepared (vtkNeuralCompressResample.h).
  if (!vtkDataSet::SafeDownCast(inputObject) && !vtkCompositeDataSet::SafeDownCast(inputObject))
  {
    vtkErrorMacro("Neural Compress: " << (inputObject ? inputObject->GetClassName() : "no")
                                      << " input; a dataset or composite dataset is needed. The output is empty.");
    return false;
  }
  vtkInformation* ai = this->GetInputArrayInformation(0);
  const char* name = ai && ai->Has(vtkDataObject::FIELD_NAME()) ? ai->Get(vtkDataObject::FIELD_NAME()) : nullptr;
  request.Association =
    ai && ai->Has(vtkDataObject::FIELD_ASSOCIATION()) ? ai->Get(vtkDataObject::FIELD_ASSOCIATION()) : -1;
  if (!name || !*name ||
    (request.Association != vtkDataObject::FIELD_ASSOCIATION_POINTS &&
      request.Association != vtkDataObject::FIELD_ASSOCIATION_CELLS))
  {
    vtkErrorMacro("Neural Compress: no input array. Select a numeric point or cell array "
                  "(SelectInputScalars). The output is empty.");
    return false;
  }
  request.ArrayName = name;
  request.InputMTime = nvi::InputStamp(inputObject, request.ArrayName, request.Association);
  std::copy(this->Internals->AnnouncedDims, this->Internals->AnnouncedDims + 3, request.AnnouncedDims);
  return true;
}

//------------------------------------------------------------------------------
nvi::InputIdentity vtkNeuralCompress::IdentityOf(
  const nvi::InputRequest& request, const std::string& canonical, double time) const
{
  nvi::InputIdentity identity;
  identity.Object = request.Source;
  // Images: the selected array and its modification time (as the training key's field); other inputs: InputStamp.
  identity.MTime = request.Array ? request.Array->GetMTime() : request.InputMTime;
  identity.ArrayObject = request.Array.GetPointer();
  identity.Array = request.ArrayName;
  identity.Association = request.Association;
  identity.Settings = canonical;
  identity.Time = time;
  return identity;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::IsCurrentTraining(const nvi::InputIdentity& identity) const
{
  const vtkInternals& in = *this->Internals;
  return in.Current && in.KeyIdentity == identity && in.Current->Time == identity.Time;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::PrepareField(
  const nvi::InputRequest& request, const nvi::Settings& settings, nvi::PreparedField& prepared)
{
  if (!request.OutOfCorePath.empty())
  {
    return this->PrepareOutOfCoreField(request, settings, prepared);
  }
  nvi::Preparation* background = nvi::Preparation::OfThisThread();
  auto stage = [background](const char* text) {
    if (background)
      background->SetStage(text);
    return !background || !background->Cancelled();
  };
  nvi::SelectedInput input;
  if (request.IsImage)
  {
    input.Image = vtkImageData::SafeDownCast(request.Object);
    input.Array = request.Array;
    input.Association = request.Association;
    if (this->Internals->GridPieceActive)
      input.Outside = this->Internals->PieceOutside(); // the domain mask, as a resampled input's
  }
  else if (!stage("resampling the input onto an image") ||
    !this->ResampleInput(request, settings.Deterministic ? 0.0 : settings.TimeBudget, input))
  {
    return false;
  }
  if (!input.Image || !input.Array || input.Image->GetNumberOfPoints() == 0)
  {
    nvReport(Error, "Neural Compress: the resampled input has no samples of '" << request.ArrayName
                                                                            << "'; nothing to train on.");
    return false;
  }
  nvi::FieldInfo& field = prepared.Field;
  std::copy(request.PieceOwned, request.PieceOwned + 6, field.PieceOwned);
  std::copy(request.PieceWhole, request.PieceWhole + 6, field.PieceWhole);
  if (!stage("reading the field") || !this->DescribeField(input, field))
  {
    return false;
  }
  prepared.Data = std::make_shared<nvi::TrainingData>();
  if (!this->ReadField(input, field, *prepared.Data))
  {
    return false;
  }
  if (input.Outside && settings.Sampling == SAMPLING_PROBE &&
    (!stage("probing points inside the cells") || !this->ProbeTrainingPoints(request.Object, field, *prepared.Data)))
  {
    return false;
  }
  prepared.Data->Field.View.valueMin = field.Stats.min;
  prepared.Data->Field.View.valueMax = field.Stats.max;
  if (!stage("hashing the field"))
  {
    return false;
  }
  prepared.TrainingSettings = settings;
  prepared.Key = nvi::TrainingKey(prepared.Data->Field.View, field, settings);
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::ResampleInput(const nvi::InputRequest& request, double timeBudget, nvi::SelectedInput& input)
{
  vtkInternals& in = *this->Internals;
  vtkDataObject* inputObject = request.Object;
  const std::string& name = request.ArrayName;
  const int assoc = request.Association;
  int64_t outsideCount = 0;
  std::string problem;
  int dims[3];
  // The dimensions RequestInformation announced (from the input data it saw), else resolved now.
  if (request.AnnouncedDims[0] > 0)
    std::copy(request.AnnouncedDims, request.AnnouncedDims + 3, dims);
  else if (!nvi::ResolveSamplingDimensions(inputObject, name, assoc, this->SamplingDimensions, dims, problem))
  {
    nvReport(Error, "Neural Compress: cannot resample the " << inputObject->GetClassName() << " input: " << problem
                                                          << ". The output is empty.");
    return false;
  }
  const bool automatic = std::all_of(
    this->SamplingDimensions, this->SamplingDimensions + 3, [](int d) { return d <= 0; });
  // Particles: their automatic image is evaluated in seconds (the trial would time the locator's setup as if it
  // were per sample); the bank is sized to the budget from the evaluation's measured cost (ProbeTrainingPoints).
  if (automatic && timeBudget > 0.0 && !nvi::IsParticleSet(inputObject) &&
    !this->FitResamplingToBudget(request, timeBudget, dims, input))
  {
    return false;
  }
  in.Resampler.SetParticleSettings(ParticleSettingsOf(this));
  if (!in.Resampler.Resample(
        inputObject, name, assoc, dims, input.Resampled, outsideCount, problem, request.Source, request.InputMTime))
  {
    nvReport(Error, "Neural Compress: cannot resample the " << inputObject->GetClassName() << " input: " << problem
                                                          << ". The output is empty.");
    return false;
  }
  input.Image = input.Resampled;
  input.Array = input.Resampled->GetPointData()->GetArray(name.c_str());
  input.Association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  input.Outside = std::make_shared<std::vector<uint8_t>>(size_t(input.Array->GetNumberOfTuples()), uint8_t(0));
  for (vtkIdType i = 0; i < input.Array->GetNumberOfTuples(); ++i)
    (*input.Outside)[size_t(i)] = std::isnan(input.Array->GetComponent(i, 0)) ? 1 : 0;
  return true;
}

//------------------------------------------------------------------------------
bool vtkNeuralCompress::FitResamplingToBudget(
  const nvi::InputRequest& request, double timeBudget, int dims[3], nvi::SelectedInput& input)
{
  const double samples = double(dims[0]) * dims[1] * dims[2];
  // A trial at about 24^3 samples measures this input's cost per sample, its cell locator's included: the estimate
  // errs on the safe side.
  const double scale = std::min(1.0, std::cbrt(13824.0 / samples));
  int trial[3];
  for (int a = 0; a < 3; ++a)
    trial[a] = dims[a] > 1 ? std::max(2, int(dims[a] * scale)) : 1;
  nvi::InputResampler probe;
  probe.SetParticleSettings(ParticleSettingsOf(this));
  vtkSmartPointer<vtkImageData> image;
  int64_t outside = 0;
  std::string problem;
  if (!probe.Resample(request.Object, request.ArrayName, request.Association, trial, image, outside, problem,
        nullptr, 0))
  {
    nvReport(Error, "Neural Compress: cannot resample the " << request.Object->GetClassName() << " input: " << problem
                                                          << ". The output is empty.");
    return false;
  }
  const double perSample = std::max(probe.SecondsPerSample(), 1e-9);
  // Its whole time is about that of building the cell locator, which the Probe bank pays again.
  this->Internals->Resampler.SetSetupSeconds(perSample * double(trial[0]) * trial[1] * trial[2]);
  const double allowed = kResampleBudgetShare * timeBudget / perSample;
  if (samples <= allowed)
    return true;
  const double shrink = std::cbrt(allowed / samples);
  std::copy(dims, dims + 3, input.DecodedDims); // the output keeps the announced geometry
  for (int a = 0; a < 3; ++a)
    dims[a] = dims[a] > 1 ? std::max(8, int(dims[a] * shrink)) : 1;
  nvReport(Warning, "Neural Compress: the input is resampled at " << dims[0] << " x " << dims[1] << " x " << dims[2]
    << " instead of " << input.DecodedDims[0] << " x " << input.DecodedDims[1] << " x " << input.DecodedDims[2]
    << " so that resampling takes at most " << int(kResampleBudgetShare * 100) << "% of the " << timeBudget
    << " s TimeBudget (measured " << perSample * 1e6 << " us per sample); set SamplingDimensions or a larger "
    "TimeBudget for a finer one.");
  return true;
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
  std::copy(image->GetDirectionMatrix()->GetData(), image->GetDirectionMatrix()->GetData() + 9, field.Direction);
  std::copy(ext, ext + 6, field.InputExtent);
  std::copy(image->GetOrigin(), image->GetOrigin() + 3, field.InputOrigin);
  std::copy(image->GetSpacing(), image->GetSpacing() + 3, field.InputSpacing);
  field.Outside = input.Outside;
  // A resampling coarsened to fit the budget decodes at the dimensions announced (the network is continuous).
  std::copy(input.DecodedDims, input.DecodedDims + 3, field.CoarsenedDims);
  field.Geometry =
    nvi::OutputGeometryOf(field, this->OutputResolution, this->FinestResolution, this->BaseResolution);
  this->ReportOutputCap(field.Geometry);
  const int64_t dims[3] = { field.Geometry.SourceDims[0], field.Geometry.SourceDims[1],
    field.Geometry.SourceDims[2] };
  // A decoded output the machine cannot hold is refused before any training (the estimate and the limit).
  nvi::CheckDecodedOutputMemory(field, this->OutputMode);
  if (dims[0] * dims[1] * dims[2] <= 0)
  {
    nvReport(Error, "Neural Compress: the input image has no " << (field.Cells ? "cells" : "points")
                                                             << "; nothing to train on.");
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::ReportEngineWarnings()
{
  for (const std::string& w : nv::takeWarnings())
    vtkWarningMacro("Neural Compress: " << w << ".");
}

//------------------------------------------------------------------------------
void vtkNeuralCompress::ReportOutputCap(const nvi::OutputGeometry& g)
{
  if (g.CapSamples <= 0)
    return;
  const int* r = this->OutputResolution;
  nvReport(Warning, "Neural Compress: OutputResolution " << r[0] << " " << r[1] << " " << r[2]
    << " is finer than the network resolves (its finest level has " << g.CapSamples << " samples per axis, decoded "
    "at most " << nv::kDecodeOversampling << "x as fine): the output is decoded at " << g.DecodedDims[0] << " x " << g.DecodedDims[1] << " x " << g.DecodedDims[2] << " instead. "
    "Raise FinestResolution for a finer network.");
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
    nvReport(Error, "Neural Compress: cannot use array '" << field.Name << "': " << problem << ".");
    return false;
  }
  field.Description = data.Field.Description;
  if (input.Outside && in.GridPieceActive)
  {
    // A rank's piece of an dataset, composite or particle set: measured on its lattice samples (the global figures).
    field.Description = field.Description.empty() ? in.PieceDescription()
                                                  : field.Description + "; " + in.PieceDescription();
  }
  else if (input.Outside)
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
    nvReport(Error, "Neural Compress: all " << field.Stats.invalid << " values of '" << field.Name
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
  int64_t count = this->ProbePoints > 0 ? this->ProbePoints : int64_t(1) << 20;
  const double budget = this->Deterministic ? 0.0 : this->TimeBudget;
  const double perPoint = in.Resampler.SecondsPerSample(); // a probed point costs about a resampled sample
  if (this->ProbePoints <= 0 && budget > 0.0 && perPoint > 0.0)
  {
    const double share = kProbeBudgetShare * budget - in.Resampler.SetupSeconds();
    const int64_t fits = static_cast<int64_t>(std::max(0.0, share) / perPoint);
    if (fits < count)
    {
      count = std::max<int64_t>(fits, int64_t(1) << 14);
      nvReport(Warning, "Neural Compress: the Probe bank holds " << count << " points instead of " << (int64_t(1) << 20)
        << " so that probing takes at most " << int(kProbeBudgetShare * 100) << "% of the " << budget
        << " s TimeBudget; set ProbePoints or a larger TimeBudget for more.");
    }
  }
  std::string problem;
  std::shared_ptr<const nvi::ProbedBank> bank =
    in.Resampler.Probe(count, uint64_t(this->Seed), this->VectorMode, this->VectorComponent, problem);
  if (!bank)
  {
    nvReport(Error, "Neural Compress: cannot probe the " << inputObject->GetClassName() << " input: " << problem
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
void vtkNeuralCompress::StartJobIfChanged(const nvi::InputIdentity& identity, const nvi::PreparedField& prepared)
{
  vtkInternals& in = *this->Internals;
  const nvi::FieldInfo& field = prepared.Field;
  in.Key = prepared.Key;
  in.KeyIdentity = identity;
  if (in.Current && in.Current->Key == in.Key && in.Current->Time == identity.Time)
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
    vtkWarningMacro("Neural Compress: " << field.Stats.invalid - outsideCount << " of "
                                        << prepared.Data->Field.View.count() << " values of '" << field.Name
                                        << "' are NaN or Inf; they are excluded from training "
                                           "and decode to finite values.");
  }
  in.Retire();
  this->StartJob(field, prepared.Data, prepared.TrainingSettings, in.Key, identity.Time);
}
