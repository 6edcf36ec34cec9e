// NeuralVolume engine: batched inference and grid decoding on the CPU.
#pragma once

#include <cstdint>

namespace nv
{

class Model;

void cpuInferPoints(const Model& model, const float* xyz, int64_t n, float* out, int threads);
/// Normalised outputs for slices [z0, z1) of an nx*ny*nz grid over [0,1]^3.
void cpuDecodeGrid(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out,
  int threads);

/// Coordinate of sample i of n along an axis: i/(n-1), 0.5 when n == 1.
inline float gridCoordinate(int64_t i, int64_t n)
{
  return n <= 1 ? 0.5f : static_cast<float>(static_cast<double>(i) / static_cast<double>(n - 1));
}

} // namespace nv
