// NeuralVolume engine: training targets by trilinear interpolation of the source volume on the CPU.
#pragma once

#include "Core/Volume.h"

#include <cstdint>

namespace nv
{

/// targets[s] = normalised value at xyz[s]; valid[s] = 0 when no finite corner exists (target set to 0).
/// Returns the number of valid samples.
int64_t sampleTargets(const VolumeView& v, const float* xyz, int64_t n, float* targets, uint8_t* valid);

} // namespace nv
