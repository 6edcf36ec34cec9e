// Private to NeuralVolume::Filters: the networks of the time steps vtkNeuralCompress has seen (its Job keeps the
// current one's).
#ifndef vtkNeuralCompressNetworkCache_h
#define vtkNeuralCompressNetworkCache_h

#include "vtkNeuralCompressJob.h" // NetworkRecord

#include <cstdint>
#include <map>
#include <vector>

namespace vtkNeuralCompressInternals
{

/// Networks of the time steps seen, within a memory cap (least recently used first out; `keep` never).
class NetworkCache
{
public:
  void Put(const NetworkRecord& record);
  const NetworkRecord* Find(double time, uint64_t key);
  /// The complete network of the nearest time before `time` (else after) with `configBytes`-compatible layout.
  const NetworkRecord* NearestForWarmStart(double time) const;
  void Trim(int64_t capBytes, double keepTime);
  std::vector<const NetworkRecord*> All() const;
  void Clear() { this->Records.clear(); }

private:
  struct Entry
  {
    NetworkRecord Record;
    uint64_t LastUse = 0;
  };
  std::map<double, Entry> Records;
  uint64_t Clock = 0;
};

} // namespace vtkNeuralCompressInternals

#endif
