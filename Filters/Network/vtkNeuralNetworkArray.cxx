#include "vtkNeuralNetworkArray.h"

#include "vtkNeuralCudaDevice.h"
#include "vtkNeuralSessionRegistry.h"

#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"

#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkInformation.h"
#include "vtkInformationDoubleVectorKey.h"
#include "vtkInformationInformationVectorKey.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkTypeUInt64Array.h"
#include "vtkUnsignedCharArray.h"

#include <cstring>

namespace
{
/// Size and stored CRC-32 of serialized bytes, after checking that the CRC matches the content
/// (so that bytes changed in place never pass for the registered network).
vtkNeuralSessionRegistry::Fingerprint VerifiedFingerprint(const uint8_t* bytes, size_t size)
{
  // Messages for users: no file:line decoration.
  if (size <= 8)
  {
    throw nv::Error("the NeuralNetwork array is too short to hold a network");
  }
  uint32_t stored = 0;
  std::memcpy(&stored, bytes + size - 4, 4);
  if (nv::crc32(bytes, size - 4) != stored)
  {
    throw nv::Error("the NeuralNetwork array is corrupt or not a NeuralVolume network (checksum mismatch)");
  }
  vtkNeuralSessionRegistry::Fingerprint f;
  f.Size = size;
  f.Crc = stored;
  return f;
}

/// The registered session of a written network (its key in the field data), or none.
void WriteSessionKey(vtkFieldData* fd, const std::shared_ptr<nv::NetworkSession>& session,
  const vtkNeuralSessionRegistry::Fingerprint& fingerprint, bool live)
{
  fd->RemoveArray(vtkNeuralNetworkArray::GetSessionKeyArrayName());
  if (!session)
  {
    return;
  }
  const vtkNeuralSessionRegistry::Key key = vtkNeuralSessionRegistry::Instance().Register(session, fingerprint, live);
  vtkNew<vtkTypeUInt64Array> keyArray;
  keyArray->SetName(vtkNeuralNetworkArray::GetSessionKeyArrayName());
  keyArray->SetNumberOfTuples(2);
  keyArray->SetValue(0, key.Process);
  keyArray->SetValue(1, key.Serial);
  fd->AddArray(keyArray);
}

/// The byte range of the network array, stored where vtkDataArray caches its ranges (the per-component range and
/// finite range; cleared by the array's next Modified()). ParaView's data information asks every field data array
/// for both, and VTK's generic range computation over a network of a few MB takes 0.1-0.2 s on each update of the
/// filter's output (state loads, every live refresh while training); this loop takes about a millisecond.
void SetKnownRange(vtkUnsignedCharArray* array)
{
  const vtkIdType n = array->GetNumberOfValues();
  if (n <= 0)
  {
    return;
  }
  const unsigned char* p = array->GetPointer(0);
  unsigned char lo = 255, hi = 0;
  for (vtkIdType i = 0; i < n; ++i)
  {
    lo = p[i] < lo ? p[i] : lo;
    hi = p[i] > hi ? p[i] : hi;
  }
  const double range[2] = { static_cast<double>(lo), static_cast<double>(hi) };
  vtkInformation* info = array->GetInformation();
  for (vtkInformationInformationVectorKey* key :
    { vtkAbstractArray::PER_COMPONENT(), vtkAbstractArray::PER_FINITE_COMPONENT() })
  {
    vtkNew<vtkInformationVector> components;
    components->SetNumberOfInformationObjects(1);
    components->GetInformationObject(0)->Set(vtkDataArray::COMPONENT_RANGE(), range, 2);
    info->Set(key, components);
  }
}
} // namespace

const char* vtkNeuralNetworkArray::GetArrayName()
{
  return "NeuralNetwork";
}

const char* vtkNeuralNetworkArray::GetSessionKeyArrayName()
{
  return "NeuralNetworkSession";
}

void vtkNeuralNetworkArray::Write(vtkFieldData* fd, const std::vector<uint8_t>& bytes,
  const std::shared_ptr<nv::NetworkSession>& session, bool live)
{
  if (!fd)
  {
    throw nv::Error("no field data to write the network to");
  }
  vtkNew<vtkUnsignedCharArray> network;
  network->SetName(GetArrayName());
  network->SetNumberOfTuples(static_cast<vtkIdType>(bytes.size()));
  if (!bytes.empty())
  {
    std::memcpy(network->GetPointer(0), bytes.data(), bytes.size());
  }
  SetKnownRange(network);
  fd->AddArray(network);
  WriteSessionKey(fd, session, session ? VerifiedFingerprint(bytes.data(), bytes.size())
                                      : vtkNeuralSessionRegistry::Fingerprint(), live);
}

const uint8_t* vtkNeuralNetworkArray::SharedNetwork::data() const
{
  return this->Array->GetPointer(0);
}

size_t vtkNeuralNetworkArray::SharedNetwork::size() const
{
  return static_cast<size_t>(this->Array->GetNumberOfValues());
}

std::shared_ptr<const vtkNeuralNetworkArray::SharedNetwork> vtkNeuralNetworkArray::Share(
  const std::vector<uint8_t>& bytes)
{
  auto shared = std::make_shared<SharedNetwork>();
  shared->Crc = VerifiedFingerprint(bytes.data(), bytes.size()).Crc;
  shared->Array = vtkSmartPointer<vtkUnsignedCharArray>::New();
  shared->Array->SetName(GetArrayName());
  shared->Array->SetNumberOfTuples(static_cast<vtkIdType>(bytes.size()));
  std::memcpy(shared->Array->GetPointer(0), bytes.data(), bytes.size());
  SetKnownRange(shared->Array);
  return shared;
}

void vtkNeuralNetworkArray::Write(vtkFieldData* fd, const std::shared_ptr<const SharedNetwork>& network,
  const std::shared_ptr<nv::NetworkSession>& session, bool live)
{
  if (!fd || !network || !network->Array)
  {
    throw nv::Error("no field data to write the network to, or no network");
  }
  fd->AddArray(network->Array);
  vtkNeuralSessionRegistry::Fingerprint fingerprint;
  fingerprint.Size = network->size();
  fingerprint.Crc = network->Crc;
  WriteSessionKey(fd, session, fingerprint, live);
}

vtkUnsignedCharArray* vtkNeuralNetworkArray::Find(vtkFieldData* fd)
{
  auto* array =
    fd ? vtkUnsignedCharArray::SafeDownCast(fd->GetAbstractArray(GetArrayName())) : nullptr;
  if (!array || array->GetNumberOfComponents() != 1 || array->GetNumberOfTuples() < 1)
  {
    return nullptr;
  }
  return array;
}

nv::Model vtkNeuralNetworkArray::Read(vtkFieldData* fd)
{
  vtkUnsignedCharArray* array = Find(fd);
  if (!array)
  {
    throw nv::Error(std::string("no '") + GetArrayName() + "' field data array");
  }
  return nv::deserialize(array->GetPointer(0), static_cast<size_t>(array->GetNumberOfTuples()));
}

std::shared_ptr<nv::NetworkSession> vtkNeuralNetworkArray::Session(vtkFieldData* fd, bool* fromBytes)
{
  vtkUnsignedCharArray* array = Find(fd);
  if (!array)
  {
    throw nv::Error(std::string("no '") + GetArrayName() + "' field data array");
  }
  const uint8_t* bytes = array->GetPointer(0);
  const size_t size = static_cast<size_t>(array->GetNumberOfTuples());
  const vtkNeuralSessionRegistry::Fingerprint fingerprint = VerifiedFingerprint(bytes, size);
  vtkNeuralSessionRegistry& registry = vtkNeuralSessionRegistry::Instance();

  auto* keyArray = vtkTypeUInt64Array::SafeDownCast(fd->GetAbstractArray(GetSessionKeyArrayName()));
  if (keyArray && keyArray->GetNumberOfValues() == 2)
  {
    vtkNeuralSessionRegistry::Key key;
    key.Process = keyArray->GetValue(0);
    key.Serial = keyArray->GetValue(1);
    if (std::shared_ptr<nv::NetworkSession> session = registry.Find(key, fingerprint))
    {
      if (fromBytes)
      {
        *fromBytes = false;
      }
      return session;
    }
  }
  if (fromBytes)
  {
    *fromBytes = true;
  }
  return registry.FindOrCreate(fingerprint, [&]() {
    const nv::Model model = nv::deserialize(bytes, size);
    nv::SessionOptions options;
    options.cudaDevice = vtkNeuralCudaDevice::Get(); // under MPI: this rank's GPU
    return std::shared_ptr<nv::NetworkSession>(nv::NetworkSession::create(nv::Device::Auto, model, options));
  });
}
