// NeuralVolume engine: the CPU renderer's macrocells -- value range per cell from a lattice of field values
// (Macrocells.h: cellRange), majorant per cell for the current transfer function (rangeMajorant). Each stage is
// recomputed only when its inputs change: ranges when the lattice (network version or grid) or the margin changes,
// majorants when the ranges or the transfer function change.
#pragma once

#include "Core/Macrocells.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace nv
{

class ThreadPool;
class CpuInference;

class CpuMacrocells
{
public:
  /// Ranges of every cell of `layout` from `lattice` (L samples per axis, x fastest, normalised, NaN ignored),
  /// widened by `margin` (Macrocells.h: cellRange). `latticeId` names the lattice's contents (a new id for every new
  /// lattice). With `net` and probesPerCell > 0 (the lattice holds that network's values), each cell's range is
  /// widened further by what the network does between lattice samples: the network is evaluated at `probesPerCell`
  /// pseudo-random points inside the cell, the range takes their values, and widens by kProbeSafety times their
  /// largest deviation from the lattice's trilinear interpolation, plus kNetworkFloor. With margin 0 and no probes
  /// the ranges are exact for trilinear interpolation of the lattice (it stays inside the hull of its samples).
  /// Returns true when the ranges were recomputed.
  bool updateRanges(ThreadPool& pool, const MacrocellLayout& layout, const float* lattice, const int64_t L[3],
    uint64_t latticeId, float margin = 0.0f, const CpuInference* net = nullptr, int probesPerCell = 0);
  static constexpr float kProbeSafety = 2.0f;
  static constexpr float kNetworkFloor = 2.0f / 1024.0f; ///< covers the fp16 rounding of the In-Shader numerics

  /// Majorants for a transfer-function table (entries r, g, b, extinction; entry coordinate y * scale + shift) whose
  /// A sparse source: the cells without a bit in `occupancy` (SourceInfo::occupancy) hold `background` exactly (the
  /// renderers give queries there that value), so their range is that value alone. Call after updateRanges().
  void setEmptyCells(const uint32_t* occupancy, float background);

  /// RenderSetup::tableKey is `tableKey`. Returns true when they were recomputed (new ranges or a new table).
  bool updateMajorants(ThreadPool& pool, const float* tf, int size, float scale, float shift, uint64_t tableKey);

  const float* majorants() const { return Majorant.data(); }
  float maxMajorant() const { return MaxMajorant; }
  int64_t cellCount() const { return static_cast<int64_t>(Lo.size()); }
  /// Cells whose majorant is 0 (empty space for the current transfer function).
  int64_t emptyCells() const { return EmptyCells; }
  float rangeLo(int64_t cell) const { return Lo[static_cast<size_t>(cell)]; }
  float rangeHi(int64_t cell) const { return Hi[static_cast<size_t>(cell)]; }

  /// The largest widening of a cell's range beyond its lattice hull in the last update (0 for exact lattices).
  float largestWidening() const { return Widening; }
  /// How often the ranges / majorants were computed (tests check the caching).
  uint64_t rangeUpdates() const { return RangesVersion; }
  uint64_t majorantUpdates() const { return MajorantUpdates; }

private:
  MacrocellLayout Layout{};
  uint64_t LatticeId = 0;
  float Margin = 0.0f;
  int Probes = 0;
  float Widening = 0.0f;
  uint64_t RangesVersion = 0; ///< incremented whenever the ranges change
  std::vector<float> Lo, Hi;

  uint64_t MajorantRanges = ~0ull;
  uint64_t TfHash = 0;
  uint64_t MajorantUpdates = 0;
  std::vector<float> Majorant;
  float MaxMajorant = 0.0f;
  int64_t EmptyCells = 0;
};

} // namespace nv
