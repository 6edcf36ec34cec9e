// NeuralVolume engine: a source of training batches that the trainer does not hold (out-of-core training: the file's
// random block buffer, OutOfCore/BlockBufferSource.h). NetworkSession::createTrainer(BatchSource&, ...) trains on it:
// before each step's batch the trainer calls prepareStep, then fill from its threads on disjoint ranges.
#pragma once

#include <cstdint>

namespace nv
{

class BatchSource
{
public:
  virtual ~BatchSource() = default;
  /// Before the samples of step `step` are drawn (never concurrent with fill): the source may change what it draws
  /// from (blocks swapped in). Errors (a file that became unreadable) are thrown from here.
  virtual void prepareStep(uint64_t step) = 0;
  /// Samples [first, first + count) of step `step`: positions xyz (interleaved, [0,1]^3), normalised targets (0 where
  /// not valid) and valid flags; safe from several threads on disjoint ranges of one step. Returns the valid count.
  virtual int64_t fill(uint64_t seed, uint64_t step, int64_t first, int64_t count, float* xyz, float* targets,
    uint8_t* valid) const = 0;
};

} // namespace nv
