// NeuralVolume engine: fp32 batched inference of a model on a thread pool (the building blocks of CpuInference:
// CpuHashGrid::encode + CpuMlp::forward on tiles of samples), for the renderer's Sample Streaming batches, grid
// decoding and macrocell lattices.
#pragma once

#include "CpuMlp.h"

#include <atomic>
#include <cstdint>
#include <vector>

namespace nv
{

class Model;
class ThreadPool;

class CpuBatchNetwork
{
public:
  static constexpr int kTile = 64;

  /// Reads the hash table of `model` in place (the model must outlive this object); transposes the MLP weights.
  explicit CpuBatchNetwork(const Model& model);

  struct Scratch
  {
    std::vector<float> enc, acts;
  };
  Scratch scratch() const;
  /// n <= kTile points.
  void evaluateTile(const float* xyz, int n, float* out, Scratch& s) const;

  /// n points, in parallel on `pool` (deterministic: each output depends only on its point).
  void evaluate(ThreadPool& pool, const float* xyz, int64_t n, float* out) const;

  /// Slices [z0, z1) of a dims[0] x dims[1] x dims[2] grid over [0,1]^3 (sample i at i/(n-1), 0.5 when n == 1), x
  /// fastest, into out (slice z0 first). When `cancel` becomes true, returns false early (out partly written).
  bool decodeSlices(ThreadPool& pool, const int64_t dims[3], int64_t z0, int64_t z1, float* out,
    const std::atomic<bool>* cancel = nullptr) const;

private:
  const Model& M;
  CpuMlp Mlp;
  std::vector<float> WT;
};

} // namespace nv
