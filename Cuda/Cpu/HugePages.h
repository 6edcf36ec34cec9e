// NeuralVolume engine: 2 MiB pages for the large buffers the CPU trainer reads and writes at random.
//
// The hash table of the paper configuration and its gradient are about 100 MB each; the encoding gathers and the
// backward scatters touch them at random, so with 4 KiB pages nearly every access also misses the TLB. Linux
// backs a range with transparent huge pages when asked (madvise), and MADV_COLLAPSE (Linux 6.1) converts pages that
// are already in use at once. Both are hints: where the kernel declines or lacks them nothing changes but speed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace nv
{

/// Ask for huge pages under [p, p + bytes) (its whole 2 MiB-aligned pages); collapse those already present.
inline void adviseHugePages(void* p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHuge = uintptr_t(2) << 20;
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
  const uintptr_t end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kHuge - 1);
  if (end <= begin)
  {
    return;
  }
  if (madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) != 0)
  {
    return;
  }
#if !defined(MADV_COLLAPSE)
  constexpr int MADV_COLLAPSE = 25; // Linux 6.1; older kernels answer EINVAL, which is ignored
#endif
  (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_COLLAPSE);
#else
  (void)p;
  (void)bytes;
#endif
}

template <class T>
void adviseHugePages(std::vector<T>& v)
{
  adviseHugePages(v.data(), v.size() * sizeof(T));
}

} // namespace nv
