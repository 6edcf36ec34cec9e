// NeuralVolume engine, out-of-core training (issue 22): a trainer's batches from a random block buffer
// (BlockBuffer.h): each step first swaps in up to `blocksPerStep` loaded blocks, then every sample is drawn from the
// resident ones and normalised by the field's value range (FileMeasure.h scans it).
//
//   nv::BlockBuffer buffer(layout, config);
//   nv::BlockBufferSource source(buffer, nv::ValueRange(lo, hi), 8);
//   auto trainer = session->createTrainer(source, trainConfig);
#pragma once

#include "BlockBuffer.h"
#include "Core/BatchSource.h"
#include "Core/ValueRange.h"

namespace nv
{

class BlockBufferSource final : public BatchSource
{
public:
  BlockBufferSource(BlockBuffer& buffer, const ValueRange& range, int blocksPerStep)
    : Buffer(buffer)
    , Range(range)
    , BlocksPerStep(blocksPerStep)
  {
  }
  void prepareStep(uint64_t step) override;
  int64_t fill(uint64_t seed, uint64_t step, int64_t first, int64_t count, float* xyz, float* targets,
    uint8_t* valid) const override;

private:
  BlockBuffer& Buffer;
  ValueRange Range;
  int BlocksPerStep;
};

} // namespace nv
