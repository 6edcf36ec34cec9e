// NeuralVolume engine, out-of-core training: a trainer's batches from the random block buffer (BlockBufferSource.h).
#include "BlockBufferSource.h"

#include <cmath>

namespace nv
{

void BlockBufferSource::prepareStep(uint64_t step)
{
  if (step > 1)
    this->Buffer.advance(this->BlocksPerStep); // the first step draws from the blocks read at the start
}

int64_t BlockBufferSource::fill(uint64_t seed, uint64_t step, int64_t first, int64_t count, float* xyz,
  float* targets, uint8_t* valid) const
{
  this->Buffer.drawSamples(count, seed, step, xyz, targets, first);
  int64_t validCount = 0;
  for (int64_t i = 0; i < count; ++i)
  {
    const bool ok = std::isfinite(targets[i]);
    targets[i] = ok ? static_cast<float>(this->Range.normalize(targets[i])) : 0.0f;
    valid[i] = ok ? 1 : 0;
    validCount += ok ? 1 : 0;
  }
  return validCount;
}

} // namespace nv
