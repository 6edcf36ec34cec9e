/**
 * @class   vtkNeuralNetworkArray
 * @brief   the NeuralNetwork field-data contract: name, writing, reading, the session behind it
 *
 * A trained network travels with a vtkImageData as two field-data arrays:
 * - `NeuralNetwork` (vtkUnsignedCharArray, one component): the model in the engine's versioned
 *   binary format (nv::serialize), ending with the CRC-32 of everything before it;
 * - `NeuralNetworkSession` (vtkTypeUInt64Array, two values): the vtkNeuralSessionRegistry key of the
 *   session that holds this network in the process that wrote it (meaningless elsewhere).
 *
 * This class is the only code that knows these names and the format: the filter writes through
 * Write(), the mapper gets its session through Session() and never parses the bytes itself.
 * Not wrapped; engine errors are nv::Error exceptions for the caller to report.
 */
#ifndef vtkNeuralNetworkArray_h
#define vtkNeuralNetworkArray_h

#include "NeuralVolumeFiltersModule.h" // for export macro

#include "vtkSmartPointer.h"      // for vtkSmartPointer
#include "vtkUnsignedCharArray.h" // for SharedNetwork::Array

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

class vtkFieldData;

namespace nv
{
class Model;
class NetworkSession;
}

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralNetworkArray
{
public:
  /// Name of the array holding the serialized network.
  static const char* GetArrayName();
  /// Name of the array holding the registry key of the session.
  static const char* GetSessionKeyArrayName();

  /// Store `bytes` (nv::serialize of the session's current network) in `fd`; when `session` is
  /// given it is registered so that renderers of this process use it instead of the bytes.
  /// `live`: the session is still training (the bytes are a snapshot; renderers show its network
  /// of the moment).
  static void Write(vtkFieldData* fd, const std::vector<uint8_t>& bytes,
    const std::shared_ptr<nv::NetworkSession>& session, bool live = false);

  /// Serialized bytes made into a NeuralNetwork array once -- in any thread: the copy, its byte range and its
  /// checksum -- then shared read-only by outputs, caches and state files: Write() adds this very array, so a live
  /// refresh or a re-execution copies nothing and renderers already using it keep their session without checking
  /// it again. Never change its bytes.
  struct SharedNetwork
  {
    vtkSmartPointer<vtkUnsignedCharArray> Array;
    uint32_t Crc = 0;
    const uint8_t* data() const;
    size_t size() const;
  };
  /// Throws nv::Error when `bytes` do not end with their checksum.
  static std::shared_ptr<const SharedNetwork> Share(const std::vector<uint8_t>& bytes);
  static void Write(vtkFieldData* fd, const std::shared_ptr<const SharedNetwork>& network,
    const std::shared_ptr<nv::NetworkSession>& session, bool live = false);

  /// The NeuralNetwork array of `fd`, or null when there is none or it is not a single-component
  /// unsigned char array (its content is not checked here).
  static vtkUnsignedCharArray* Find(vtkFieldData* fd);

  /// The model stored in `fd` (format, version and checksum checked); throws nv::Error.
  static nv::Model Read(vtkFieldData* fd);

  /// The session of the network stored in `fd`: the one registered by the filter of this process
  /// when its key and bytes match, else a session created once from the bytes and shared by every
  /// caller with the same bytes. `fromBytes` (optional) tells which. Throws nv::Error (no array,
  /// corrupt bytes, no usable device).
  static std::shared_ptr<nv::NetworkSession> Session(vtkFieldData* fd, bool* fromBytes = nullptr);

private:
  vtkNeuralNetworkArray() = delete;
};

#endif
