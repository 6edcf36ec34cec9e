#include "vtkNeuralCompressNetworkCache.h"

#include <iterator>

namespace vtkNeuralCompressInternals
{

//------------------------------------------------------------------------------
void NetworkCache::Put(const NetworkRecord& record)
{
  Entry& e = this->Records[record.Time];
  e.Record = record;
  e.LastUse = ++this->Clock;
}

const NetworkRecord* NetworkCache::Find(double time, uint64_t key)
{
  auto it = this->Records.find(time);
  if (it == this->Records.end() || it->second.Record.Key != key)
  {
    return nullptr;
  }
  it->second.LastUse = ++this->Clock;
  return &it->second.Record;
}

const NetworkRecord* NetworkCache::NearestForWarmStart(double time) const
{
  const NetworkRecord* best = nullptr;
  auto it = this->Records.lower_bound(time);
  if (it != this->Records.begin())
  {
    best = &std::prev(it)->second.Record; // the latest time before
  }
  else if (it != this->Records.end() && it->first != time)
  {
    best = &it->second.Record;
  }
  else if (it != this->Records.end() && std::next(it) != this->Records.end())
  {
    best = &std::next(it)->second.Record;
  }
  return best;
}

void NetworkCache::Trim(int64_t capBytes, double keepTime)
{
  for (;;)
  {
    int64_t total = 0;
    auto oldest = this->Records.end();
    for (auto it = this->Records.begin(); it != this->Records.end(); ++it)
    {
      total += it->second.Record.Bytes ? static_cast<int64_t>(it->second.Record.Bytes->size()) : int64_t(0);
      if (it->first != keepTime && (oldest == this->Records.end() || it->second.LastUse < oldest->second.LastUse))
      {
        oldest = it;
      }
    }
    if (total <= capBytes || oldest == this->Records.end())
    {
      return;
    }
    this->Records.erase(oldest);
  }
}

std::vector<const NetworkRecord*> NetworkCache::All() const
{
  std::vector<const NetworkRecord*> all;
  for (const auto& e : this->Records)
  {
    all.push_back(&e.second.Record);
  }
  return all;
}

} // namespace vtkNeuralCompressInternals
