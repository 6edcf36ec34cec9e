// NeuralVolume engine: the scheduling priority of the calling thread, for work that runs beside an interactive
// application (TrainConfig::lowPriority).
#pragma once

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace nv
{

/// Niceness added to the threads of a low-priority run: CFS then gives a thread of niceness 0 about 9x the share of
/// one of these when both want a core, and the run keeps every core the application leaves idle.
constexpr int kLowPriorityNiceness = 10;

/// Lowers the calling thread's priority to kLowPriorityNiceness (Linux: per-thread niceness; elsewhere nothing).
/// Raising it back needs privileges, so a thread lowered here stays lowered: call it in threads the run owns.
inline void lowerCurrentThreadPriority()
{
#if defined(__linux__)
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  if (getpriority(PRIO_PROCESS, tid) < kLowPriorityNiceness)
    setpriority(PRIO_PROCESS, tid, kLowPriorityNiceness);
#endif
}

} // namespace nv
