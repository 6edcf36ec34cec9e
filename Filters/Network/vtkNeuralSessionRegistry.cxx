#include "vtkNeuralSessionRegistry.h"

#include "Core/NetworkSession.h"

#include <chrono>
#include <map>
#include <mutex>
#include <random>
#include <utility>

struct vtkNeuralSessionRegistry::vtkInternals
{
  struct Registered
  {
    std::weak_ptr<nv::NetworkSession> Session;
    uint64_t Version = 0;
    Fingerprint Bytes;
    bool Live = false;
  };
  std::mutex Mutex;
  uint64_t NextSerial = 1;
  std::map<uint64_t, Registered> BySerial;
  std::map<std::pair<size_t, uint32_t>, std::weak_ptr<nv::NetworkSession>> ByBytes;
  int64_t Created = 0;

  /// Drop entries whose session is gone (called under the lock on every registration).
  void Prune()
  {
    for (auto it = BySerial.begin(); it != BySerial.end();)
      it = it->second.Session.expired() ? BySerial.erase(it) : std::next(it);
    for (auto it = ByBytes.begin(); it != ByBytes.end();)
      it = it->second.expired() ? ByBytes.erase(it) : std::next(it);
  }
};

vtkNeuralSessionRegistry& vtkNeuralSessionRegistry::Instance()
{
  // Never destroyed: mappers and filters may release sessions during static destruction.
  static vtkNeuralSessionRegistry* instance = new vtkNeuralSessionRegistry;
  return *instance;
}

vtkNeuralSessionRegistry::vtkNeuralSessionRegistry()
  : Internals(new vtkInternals)
{
  // A token that differs between processes (and runs), so that a key carried to another process
  // by a state file or a data transfer never matches there.
  std::random_device device;
  std::seed_seq seq{ device(), device(),
    static_cast<unsigned>(std::chrono::steady_clock::now().time_since_epoch().count()),
    static_cast<unsigned>(reinterpret_cast<uintptr_t>(this)) };
  std::mt19937_64 rng(seq);
  do
  {
    this->ProcessToken = rng();
  } while (this->ProcessToken == 0);
}

vtkNeuralSessionRegistry::~vtkNeuralSessionRegistry() = default;

vtkNeuralSessionRegistry::Key vtkNeuralSessionRegistry::Register(
  const std::shared_ptr<nv::NetworkSession>& session, const Fingerprint& bytes, bool live)
{
  vtkInternals& in = *this->Internals;
  std::lock_guard<std::mutex> lock(in.Mutex);
  in.Prune();
  Key key;
  key.Process = this->ProcessToken;
  key.Serial = in.NextSerial++;
  vtkInternals::Registered entry;
  entry.Session = session;
  entry.Version = session ? session->version() : 0;
  entry.Bytes = bytes;
  entry.Live = live;
  in.BySerial[key.Serial] = entry;
  return key;
}

std::shared_ptr<nv::NetworkSession> vtkNeuralSessionRegistry::Find(const Key& key, const Fingerprint& bytes)
{
  if (key.Process != this->ProcessToken)
  {
    return nullptr;
  }
  vtkInternals& in = *this->Internals;
  std::lock_guard<std::mutex> lock(in.Mutex);
  auto it = in.BySerial.find(key.Serial);
  if (it == in.BySerial.end() || !(it->second.Bytes == bytes))
  {
    return nullptr;
  }
  std::shared_ptr<nv::NetworkSession> session = it->second.Session.lock();
  // A session retrained since the bytes were written holds another network.
  if (!session || (!it->second.Live && session->version() != it->second.Version))
  {
    return nullptr;
  }
  return session;
}

std::shared_ptr<nv::NetworkSession> vtkNeuralSessionRegistry::FindOrCreate(
  const Fingerprint& bytes, const std::function<std::shared_ptr<nv::NetworkSession>()>& create)
{
  vtkInternals& in = *this->Internals;
  std::lock_guard<std::mutex> lock(in.Mutex);
  auto& slot = in.ByBytes[std::make_pair(bytes.Size, bytes.Crc)];
  if (std::shared_ptr<nv::NetworkSession> existing = slot.lock())
  {
    return existing;
  }
  // Created under the lock: two mappers asking for the same bytes at once get one session.
  std::shared_ptr<nv::NetworkSession> session = create();
  slot = session;
  ++in.Created;
  return session;
}

int64_t vtkNeuralSessionRegistry::GetSessionsCreated() const
{
  std::lock_guard<std::mutex> lock(this->Internals->Mutex);
  return this->Internals->Created;
}
