// NeuralVolume engine: batched inference and grid decoding on the CPU.
#pragma once

#include "CpuMlp.h"

#include <cstdint>
#include <vector>

namespace nv
{

class Model;
class ThreadPool;

/// Coordinate of sample i of n along an axis: i/(n-1), 0.5 when n == 1.
inline float gridCoordinate(int64_t i, int64_t n)
{
  return n <= 1 ? 0.5f : static_cast<float>(static_cast<double>(i) / static_cast<double>(n - 1));
}

/// A model in the form the CPU forward pass reads (transposed MLP weights), built once per parameter version.
/// Keeps a reference to the model: it must outlive the evaluator and keep its parameters.
class CpuInference
{
public:
  static constexpr int kTile = 64;

  explicit CpuInference(const Model& model);

  /// Per-thread buffers of evaluate().
  struct Scratch
  {
    std::vector<float> enc, acts;
  };
  Scratch scratch() const;

  /// Normalised outputs of n <= kTile points, on the calling thread.
  void evaluate(const float* xyz, int n, float* out, Scratch& s) const;
  /// Normalised outputs at n points (xyz interleaved, [0,1]), on the pool.
  void inferPoints(ThreadPool& pool, const float* xyz, int64_t n, float* out) const;
  /// Normalised outputs for slices [z0, z1) of an nx*ny*nz grid over [0,1]^3, on the pool.
  void decodeGrid(ThreadPool& pool, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out) const;

private:
  const Model& Network;                 ///< the model evaluated (its hash table read in place)
  CpuMlp Mlp;
  std::vector<float> TransposedWeights; ///< the MLP's layers transposed, [in][out] (CpuMlp::transpose)
};

} // namespace nv
