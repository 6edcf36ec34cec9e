// The CPU thread pool under thread limits (Cpu/ThreadPool.h): absurd Threads values are capped with a warning, and a
// pool whose threads the system refuses works with the ones it got, without hanging, and says so once.
#include "ForkedChild.h"
#include "TestHarness.h"

#include "Core/EngineWarnings.h"
#include "Core/ResourceEstimate.h"
#include "Cpu/ThreadPool.h"

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <sys/resource.h>

namespace
{
/// Sum of 0..n-1 over the pool's parallelFor and parallelChunks: the work is done by the workers there are.
bool sumsRight(nv::ThreadPool& pool, int64_t n)
{
  std::atomic<int64_t> a(0), b(0);
  pool.parallelFor(n, [&](int64_t i0, int64_t i1, int) {
    for (int64_t i = i0; i < i1; ++i)
      a += i;
  });
  pool.parallelChunks(n, 7, [&](int64_t i0, int64_t i1, int) {
    for (int64_t i = i0; i < i1; ++i)
      b += i;
  });
  return a.load() == n * (n - 1) / 2 && b.load() == n * (n - 1) / 2;
}

bool posted(const std::vector<std::string>& warnings, const std::string& text)
{
  for (const std::string& w : warnings)
    if (w.find(text) != std::string::npos)
      return true;
  return false;
}
} // namespace

NV_TEST(absurd_thread_counts_are_capped)
{
  const int hardware = nv::ThreadPool::defaultThreads();
  std::string why;
  EXPECT_TRUE(nv::ThreadPool::usableThreads(0, &why) == hardware && why.empty());
  EXPECT_TRUE(nv::ThreadPool::usableThreads(3, &why) == 3 && why.empty());
  EXPECT_TRUE(nv::ThreadPool::usableThreads(1 << 30, &why) == 4 * hardware);
  EXPECT_TRUE(why.find("Threads 1073741824 is more than 4 x the") == 0);
  const int rc = nvtest::runInChild(
    [] {
      nv::ThreadPool pool(1024);
      const std::vector<std::string> w = nv::takeWarnings();
      if (pool.size() != 4 * nv::ThreadPool::defaultThreads() || !posted(w, "Threads 1024 is more than"))
        return 1;
      nv::ThreadPool again(1024); // the same warning is not posted twice
      return sumsRight(pool, 100000) && nv::takeWarnings().empty() ? 0 : 2;
    },
    60.0);
  EXPECT_TRUE(rc == 0);
}

NV_TEST(refused_threads_leave_a_working_pool)
{
  if (nvtest::skipAddressSpaceLimits())
    return;
  // In a child: the address space capped 20 MB above what the process maps, so that only a few 8 MB thread stacks
  // fit. The pool works with the threads it got (at least the caller's), posts "could create only N of M threads",
  // and its destructor returns (it joins only the threads that exist).
  const int rc = nvtest::runInChild(
    [] {
      const int asked = 4 * nv::ThreadPool::defaultThreads();
      const nv::ProcessMemoryLimits used = nv::processMemoryLimits();
      struct rlimit r;
      getrlimit(RLIMIT_AS, &r);
      r.rlim_cur = static_cast<rlim_t>(used.addressSpaceUsed + (int64_t(20) << 20));
      if (setrlimit(RLIMIT_AS, &r) != 0)
        return 10;
      int size = 0;
      bool right = false;
      {
        nv::ThreadPool pool(asked);
        size = pool.size();
        right = sumsRight(pool, 1000000);
      }
      const std::vector<std::string> w = nv::takeWarnings();
      std::printf("    %d of %d threads; %s\n", size, asked, w.empty() ? "no warning" : w[0].c_str());
      if (size < 1 || size >= asked)
        return 11;
      if (!right)
        return 12;
      return posted(w, "could create only " + std::to_string(size) + " of " + std::to_string(asked) + " threads")
        ? 0
        : 13;
    },
    60.0);
  std::printf("    child: %d\n", rc);
  EXPECT_TRUE(rc == 0);
}

NV_TEST_MAIN()
