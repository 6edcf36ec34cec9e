// Engine tests: runs a check in a forked child process, so that limits it lowers (setrlimit) and threads it leaves
// behind do not touch the test process; a child that hangs is killed.
#pragma once

#include <chrono>
#include <cstdio>
#include <functional>
#include <thread>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

namespace nvtest
{
/// AddressSanitizer reserves terabytes of shadow address space: a child with a lowered RLIMIT_AS cannot run under it
/// (its reports say "Failed to mmap"); such checks are skipped in the sanitized build and run in the plain one.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

/// True (after saying so) when address-space limits cannot be tested in this build.
inline bool skipAddressSpaceLimits()
{
  if (kAddressSanitizer)
    std::printf("    skipped under AddressSanitizer (address-space limits; the plain build runs it)\n");
  return kAddressSanitizer;
}

/// Exit status of fn() run in a child; 128 + signal when it was killed by one; -1 when it ran past `seconds` (it is
/// killed then) or could not be forked. Call it before the process starts threads of its own.
inline int runInChild(const std::function<int()>& fn, double seconds)
{
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid < 0)
    return -1;
  if (pid == 0)
  {
    int rc = 99;
    try
    {
      rc = fn();
    }
    catch (...)
    {
      rc = 98;
    }
    std::fflush(stdout);
    _exit(rc);
  }
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end)
  {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid)
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  return -1;
}
} // namespace nvtest
