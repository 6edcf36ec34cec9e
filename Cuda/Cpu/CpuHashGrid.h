// NeuralVolume engine: hash-grid encoding on the CPU (forward and backward).
#pragma once

#include "Core/HashGridMath.h"

#include <cstdint>

namespace nv
{

class CpuHashGrid
{
public:
  /// out[s * L*F + l*F + f] for n points xyz (interleaved, [0,1]).
  static void encode(const GridLayout& g, const float* table, const float* xyz, int64_t n, float* out);

  /// gradTable += dL/dtable for levels [levelBegin, levelEnd), given dL/dout (same layout as encode's out).
  /// Samples are visited in order, so the result is deterministic.
  static void backwardLevels(const GridLayout& g, const float* xyz, int64_t n, const float* dOut, float* gradTable,
    int levelBegin, int levelEnd);
};

} // namespace nv
