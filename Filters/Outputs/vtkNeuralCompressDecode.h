// Private to NeuralVolume::Filters: the decoded output of vtkNeuralCompress (OutputMode "Decoded ..."), decoded in
// chunks on the session's threads with progress and abort, after its memory has been checked against the machine.
#ifndef vtkNeuralCompressDecode_h
#define vtkNeuralCompressDecode_h

#include "vtkNeuralCompressJob.h"

#include "Core/Error.h"

#include <functional>

namespace vtkNeuralCompressInternals
{

/// What a long decode reports to and asks of its caller, between chunks of about kDecodeChunk samples.
struct DecodeControl
{
  std::function<bool()> Abort;          ///< true: stop (DecodeAborted is thrown)
  std::function<void(double)> Progress; ///< fraction of the samples decoded
};

/// Samples decoded between two polls of DecodeControl.
constexpr int64_t kDecodeChunk = int64_t(1) << 20;

/// Thrown when DecodeControl::Abort said so.
class DecodeAborted : public nv::Error
{
public:
  DecodeAborted()
    : nv::Error("decoding the output was aborted.")
  {
  }
};

/// Host bytes the decoded output of `field` in `outputMode` takes while it is made (the array, a typed copy, the
/// measurement's buffer); 0 for OUTPUT_NETWORK_ONLY. Saturates instead of overflowing.
int64_t DecodedOutputBytes(const FieldInfo& field, int outputMode);

/// Throws nv::Error naming the estimate and the limit when the decoded output would not fit in host memory.
void CheckDecodedOutputMemory(const FieldInfo& field, int outputMode);

/// The decoded output field in the requested type (OutputMode), or null for OUTPUT_NETWORK_ONLY. Checks the memory
/// first (nv::Error), polls `control` between chunks (DecodeAborted).
vtkSmartPointer<vtkDataArray> DecodeOutput(
  nv::NetworkSession& session, const FieldInfo& field, int outputMode, const DecodeControl& control = DecodeControl());

/// The error of a decoded output on the source's grid against the source, measured on the output's own values
/// (rounded, clamped or thresholded to the input's type), as nv::compareDecoded measures a float grid.
nv::ErrorStats CompareDecodedOutput(
  vtkDataArray* decoded, const nv::VolumeView& source, double valueMin, double valueMax, int threads);

} // namespace vtkNeuralCompressInternals

#endif
