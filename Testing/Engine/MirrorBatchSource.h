// A BatchSource (Core/BatchSource.h) that draws exactly what a trainer on the volume draws (randomPoint positions,
// sampleTargets values): a trainer fed by it must follow the volume trainer bit for bit (CPU) or within the GPU's
// tolerances. Counts prepareStep calls.
#pragma once

#include "Core/BatchSource.h"
#include "Core/HashGridMath.h"
#include "Cpu/CpuSampler.h"

#include <atomic>
#include <vector>

namespace nvtest
{
class MirrorBatchSource final : public nv::BatchSource
{
public:
  explicit MirrorBatchSource(const nv::VolumeView& volume)
    : Volume(volume)
  {
  }
  void prepareStep(uint64_t step) override { LastStep = step; ++Prepared; }
  int64_t fill(uint64_t seed, uint64_t step, int64_t first, int64_t count, float* xyz, float* targets,
    uint8_t* valid) const override
  {
    for (int64_t i = 0; i < count; ++i)
      nv::randomPoint(seed, step, static_cast<uint64_t>(first + i), xyz + 3 * i);
    return nv::sampleTargets(Volume, xyz, count, targets, valid);
  }
  uint64_t LastStep = 0;
  std::atomic<int> Prepared{ 0 };

private:
  nv::VolumeView Volume;
};
} // namespace nvtest
