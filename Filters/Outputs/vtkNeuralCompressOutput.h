// Private to NeuralVolume::Filters: the outputs of vtkNeuralCompress built from a network record (the decoded image
// with its field data, the training log, the metrics table), the summary line, and the text form of the networks a
// state file carries.
#ifndef vtkNeuralCompressOutput_h
#define vtkNeuralCompressOutput_h

#include "vtkNeuralCompressJob.h"

#include <map>
#include <string>
#include <vector>

class vtkDataArray;
class vtkImageData;
class vtkInformation;
class vtkTable;

namespace vtkNeuralCompressInternals
{

/// Output 0: the geometry of `field`, the decoded array (may be null), the network and its numbers as field data.
/// `live`: the session is still training (renderers of this process show its network of the moment).
void FillImage(vtkImageData* output, const FieldInfo& field, const NetworkRecord& record, vtkDataArray* decoded,
  const std::shared_ptr<nv::NetworkSession>& session, bool live);

/// Output 1: one row per step of `record` (the last row's PSNR is the final one when it is known); no row for a log
/// of one row (a line chart cannot draw one point).
void FillLog(vtkTable* log, const NetworkRecord& record);
void InitializeLog(vtkTable* log);

/// Output 2: one row per network, ordered by time.
void FillMetrics(vtkTable* metrics, const std::vector<const NetworkRecord*>& records);
void InitializeMetrics(vtkTable* metrics);

/// Outputs without a network: empty tables and an image of the geometry promised in `outInfo` (its whole extent,
/// origin and spacing), so the pipeline does not execute again for a geometry it did not announce. `bounds`
/// (optional): a resampled input's bounds, which its image spans (RequestInformation announces only its extent).
void InitializeOutputs(
  vtkImageData* output, vtkTable* log, vtkTable* metrics, vtkInformation* outInfo, const double* bounds = nullptr);
/// Empty outputs over `bounds` (null: none) whose NeuralTrainingState says "Preparing": the field or the job's first
/// network is still being made; a Neural Volume draws nothing and reports no error.
void InitializePreparingOutputs(
  vtkImageData* output, vtkTable* log, vtkTable* metrics, vtkInformation* outInfo, const double* bounds);

/// The line printed when a network is complete; `fromCache`: the network of this time step was trained before and
/// taken from the filter's cache.
std::string Summary(
  const FieldInfo& field, const Job& job, const NetworkRecord& record, double targetRatio, bool fromCache);

/// Why a network was not trained further, in words ("constant field", "Training Steps is 0: ...", "target PSNR"):
/// the record's end reason, except that a field that is not constant and got no step was not trained on request.
std::string EndReasonText(const FieldInfo& field, const Metrics& metrics);
/// True for a network that had no training because TrainingSteps was 0 (a field that is not constant).
bool UntrainedByRequest(const FieldInfo& field, const Metrics& metrics);
/// What to do about an image whose geometry a network cannot state (zero or negative spacing on an axis of more than
/// one sample), for the error that refuses it.
std::string SpacingAdvice(const double spacing[3], const int64_t dims[3]);

/// What makes a smaller model of `job`'s configuration (a ratio below 1:1: the model is larger than the field),
/// e.g. "a smaller Log2 Table Size, fewer Levels, 8-bit (entropy coded) storage"; empty when nothing does.
std::string SmallerModelAdvice(const Job& job);

/// True when the max error in source units exceeds the largest double (MaxError inf) while every decoded value is
/// finite (its share of the range, MaxErrorOfRange, is finite): a figure too large for a double, not a divergence.
bool MaxErrorOverflows(const Metrics& metrics);
/// The max error for messages: in source units (computed in extended precision where it exceeds the largest double,
/// with its share of the range).
std::string MaxErrorText(const FieldInfo& field, const Metrics& metrics);

/// "nvnet1;<key hex>:<base64>;..." and back (entries that do not parse are skipped; `error` says why).
std::string EncodeNetworks(const std::vector<const NetworkRecord*>& records);
std::map<uint64_t, std::vector<uint8_t>> DecodeNetworks(const std::string& text, std::string& error);

} // namespace vtkNeuralCompressInternals

#endif
