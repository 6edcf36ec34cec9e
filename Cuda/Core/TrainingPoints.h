// NeuralVolume engine: a bank of training points -- positions with their target values -- for sources that are not
// a regular volume (values probed inside the cells of an unstructured grid at random points, the active voxels and
// background samples of a sparse OpenVDB grid). A trainer on a bank draws each step's batch from it at random
// (randomBankIndex: the same draw on the CPU and the GPU).
#pragma once

#include "HashGridMath.h"
#include "HostDevice.h"

#include <cstdint>

namespace nv
{

/// count points: xyz interleaved in [0,1]^3 (the network's domain) and their normalised target values (NaN: not
/// trained on). Host memory; the caller keeps it alive while a trainer uses it.
struct TrainingPoints
{
  const float* xyz = nullptr;
  const float* values = nullptr;
  int64_t count = 0;
};

/// Bank index of sample `index` of step `step`: uniform over [0, count) (a 64-bit hash, multiply-shift reduction;
/// independent of threads and launch shape).
NV_HD int64_t randomBankIndex(uint64_t seed, uint64_t step, uint64_t index, int64_t count)
{
  const uint64_t h = mix64(mix64(seed * 0xC2B2AE3D27D4EB4Full + step) ^ (index * 0x9E3779B97F4A7C15ull));
  // The high 64 bits of h * count: uniform without a division.
#if defined(__CUDA_ARCH__)
  return static_cast<int64_t>(__umul64hi(h, static_cast<uint64_t>(count)));
#else
  return static_cast<int64_t>((static_cast<unsigned __int128>(h) * static_cast<uint64_t>(count)) >> 64);
#endif
}

} // namespace nv
