#include "EngineWarnings.h"

#include <mutex>
#include <set>

namespace nv
{
namespace
{
struct WarningQueue
{
  std::mutex Mutex;
  std::set<std::string> Seen;
  std::vector<std::string> Pending;
};

WarningQueue& queue()
{
  static WarningQueue q;
  return q;
}
} // namespace

void postWarning(const std::string& message)
{
  WarningQueue& q = queue();
  std::lock_guard<std::mutex> lock(q.Mutex);
  if (q.Seen.insert(message).second)
    q.Pending.push_back(message);
}

std::vector<std::string> takeWarnings()
{
  WarningQueue& q = queue();
  std::lock_guard<std::mutex> lock(q.Mutex);
  std::vector<std::string> out;
  out.swap(q.Pending);
  return out;
}

} // namespace nv
