// Command-line choice of the GPU kernel variants (nv::KernelOptions) for the benchmarks and GPU tests:
//   --fwd-mode=0|1|2 --bin-bits=-1..8 --lpt=1|2|4 --scratch-mb=N --two-pass=-1|0|1 --wmma --in-shader-fp32
//   --smem-limit=BYTES (shared memory per block, e.g. 101376 as on sm_86/89/120, 65536 as on sm_75)
//   --stream-queries=N (Sample Streaming: queries per wavefront batch at most; default one inference chunk, <= 2^23)
// Flags are removed from argv so the remaining arguments keep their positions.
#pragma once

#include "Core/NetworkSession.h"

#include <cstdlib>
#include <cstring>
#include <string>

namespace nvbench
{

inline nv::KernelOptions parseKernelFlags(int& argc, char** argv)
{
  nv::KernelOptions o;
  int out = 1;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto value = [&](const char* key, int& dst) {
      const size_t n = std::strlen(key);
      if (a.compare(0, n, key) != 0)
        return false;
      dst = std::atoi(a.c_str() + n);
      return true;
    };
    if (value("--fwd-mode=", o.forwardMode) || value("--bin-bits=", o.binBitsPerAxis) ||
      value("--lpt=", o.encodeLevelsPerThread) || value("--scratch-mb=", o.encodeScratchMiB) ||
      value("--two-pass=", o.trainTwoPass) || value("--smem-limit=", o.sharedMemoryLimit))
      continue;
    int streamQueries = 0;
    if (value("--stream-queries=", streamQueries))
    {
      o.streamBatchQueries = streamQueries;
      continue;
    }
    if (a == "--wmma")
    {
      o.trainRegisterResident = false;
      continue;
    }
    if (a == "--in-shader-fp32")
    {
      o.inShaderHalfAccumulate = false;
      continue;
    }
    argv[out++] = argv[i];
  }
  argc = out;
  return o;
}

} // namespace nvbench
