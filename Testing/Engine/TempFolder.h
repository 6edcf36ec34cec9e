// A temporary folder for the engine tests that write files (made on first use, removed by runCasesInTempFolder).
#pragma once

#include "TestHarness.h"

#include <cstdio>
#include <cstdlib>
#include <string>
#include <unistd.h>

namespace nvtest
{
/// The test's own folder under /tmp (one per process).
inline const std::string& tempFolder()
{
  static std::string dir;
  if (dir.empty())
  {
    char pattern[] = "/tmp/nvEngineTestXXXXXX";
    const char* made = mkdtemp(pattern);
    dir = made ? made : "/tmp";
  }
  return dir;
}

/// runCases, then the folder removed.
inline int runCasesInTempFolder(int argc, char** argv)
{
  const int result = runCases(argc, argv);
  const std::string cleanup = "rm -rf '" + tempFolder() + "'";
  if (tempFolder() != "/tmp" && std::system(cleanup.c_str()) != 0)
    std::printf("could not remove %s\n", tempFolder().c_str());
  return result;
}
} // namespace nvtest
