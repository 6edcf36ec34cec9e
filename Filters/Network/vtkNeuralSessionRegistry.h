/**
 * @class   vtkNeuralSessionRegistry
 * @brief   process-wide registry of live network sessions (not wrapped)
 *
 * Lets the Neural Volume mapper render with the very nv::NetworkSession the Neural Compress filter
 * trained when both run in the same process (builtin GUI session, pvpython, pvbatch, a pvserver):
 * no second deserialization and no second upload of the model. Every other consumer of a
 * serialized network (a state file, a client-server render server, a saved .vti) gets a session
 * created once from the bytes and shared by everybody who renders the same bytes.
 *
 * Entries hold weak references: a session lives as long as its owners (the filter, the mappers)
 * keep it. A filter's entry matches only while the session still holds the network that was
 * serialized (same version) and the bytes have the registered size and CRC-32.
 * Use it through vtkNeuralNetworkArray; it is thread-safe.
 */
#ifndef vtkNeuralSessionRegistry_h
#define vtkNeuralSessionRegistry_h

#include "NeuralVolumeFiltersModule.h" // for export macro

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>

namespace nv
{
class NetworkSession;
}

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralSessionRegistry
{
public:
  static vtkNeuralSessionRegistry& Instance();

  /// Identifies a registered session: a random token of this process and a serial number.
  struct Key
  {
    uint64_t Process = 0;
    uint64_t Serial = 0;
  };

  /// The bytes a session's network was serialized to.
  struct Fingerprint
  {
    size_t Size = 0;
    uint32_t Crc = 0;
    bool operator==(const Fingerprint& o) const { return Size == o.Size && Crc == o.Crc; }
  };

  /// Registers the session that holds the network serialized to `bytes` (in its current version).
  /// `live`: the session is training and the bytes are a snapshot; Find() returns it whatever its
  /// version, so renderers show the network of the moment.
  Key Register(const std::shared_ptr<nv::NetworkSession>& session, const Fingerprint& bytes, bool live = false);

  /// The session registered under `key` in this process, when it is alive, still holds the network
  /// of that version (any version for a live entry) and was registered for `bytes`; else null.
  std::shared_ptr<nv::NetworkSession> Find(const Key& key, const Fingerprint& bytes);

  /// The session created from these bytes by an earlier call, or a new one from `create()`.
  std::shared_ptr<nv::NetworkSession> FindOrCreate(
    const Fingerprint& bytes, const std::function<std::shared_ptr<nv::NetworkSession>()>& create);

  uint64_t GetProcessToken() const { return this->ProcessToken; }

  /// Sessions created from bytes so far (for tests: the mapper must not deserialize a network the
  /// filter of the same process trained).
  int64_t GetSessionsCreated() const;

  vtkNeuralSessionRegistry(const vtkNeuralSessionRegistry&) = delete;
  vtkNeuralSessionRegistry& operator=(const vtkNeuralSessionRegistry&) = delete;

private:
  vtkNeuralSessionRegistry();
  ~vtkNeuralSessionRegistry();

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
  uint64_t ProcessToken = 0;
};

#endif
