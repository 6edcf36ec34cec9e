// NeuralVolume engine: error-guided training samples (TrainConfig::importanceGrid). A coarse grid of G^3 cells over
// [0,1)^3 holds per-cell weights -- an exponential moving average of the mean |network - target| of the training
// samples that fell in the cell -- refreshed every kImportanceInterval steps. The even samples of a batch are the
// uniform points of randomPoint (the same as without importance); each odd sample picks a cell with probability
// proportional to its weight (a 64-bit integer CDF: exact, the same draw on the CPU and the GPU) and a uniform point
// inside it. Errors are summed in fixed point, so the weights do not depend on the summation order (threads, atomics).
// The loss is not reweighted: half the batch trains the uniform objective, half concentrates where the error is.
#pragma once

#include "HashGridMath.h"
#include "HostDevice.h"

#include <cstdint>

namespace nv
{

constexpr int kImportanceInterval = 16;      ///< steps between two refreshes of the weights
constexpr float kImportanceEma = 0.3f;       ///< weight of a refresh's measurement in the moving average
constexpr float kImportanceErrorScale = 1048576.0f; ///< fixed point of the per-cell error sums (2^20)
constexpr float kImportanceWeightMax = 16.0f; ///< weights are clamped here before they are quantised

/// Cell index (x fastest) of a point of [0,1)^3 in a grid of `cells` per axis.
NV_HD int importanceCell(const float x[3], int cells)
{
  int c[3];
  for (int d = 0; d < 3; ++d)
  {
    int i = static_cast<int>(x[d] * static_cast<float>(cells));
    i = i < 0 ? 0 : (i >= cells ? cells - 1 : i);
    c[d] = i;
  }
  return (c[2] * cells + c[1]) * cells + c[0];
}

/// Fixed-point amount added to a cell's error sum for a sample with normalised absolute error e (integer sums:
/// exact whatever the order of the additions).
NV_HD uint64_t importanceFixedError(float e)
{
  e = e < kImportanceWeightMax ? e : kImportanceWeightMax; // also maps NaN to the clamp
  e = e > 0.0f ? e : 0.0f;
  return static_cast<uint64_t>(e * kImportanceErrorScale + 0.5f);
}

/// New weight of a cell from its previous weight (negative or NaN: never measured) and the error sum / count of
/// the samples that fell in it since the last refresh (count 0: unchanged).
NV_HD float importanceUpdate(float previous, uint64_t sum, uint32_t count)
{
  if (count == 0)
    return previous;
  const float mean = static_cast<float>(static_cast<double>(sum) / static_cast<double>(count)) / kImportanceErrorScale;
  return !(previous >= 0.0f) ? mean : previous + kImportanceEma * (mean - previous);
}

/// Integer weight of a cell for the CDF (0 for a cell never measured).
NV_HD uint64_t importanceQuantize(float w)
{
  if (!(w > 0.0f))
    return 0;
  w = w < kImportanceWeightMax ? w : kImportanceWeightMax;
  return static_cast<uint64_t>(w * kImportanceErrorScale + 0.5f);
}

/// High 64 bits of a * b.
NV_HD uint64_t importanceMulHi(uint64_t a, uint64_t b)
{
#if defined(__CUDA_ARCH__)
  return __umul64hi(a, b);
#else
  return static_cast<uint64_t>((static_cast<unsigned __int128>(a) * b) >> 64);
#endif
}

/// Training point `index` of step `step`: even indices (and every index while the CDF is empty) are randomPoint's
/// uniform points; odd ones a cell drawn from cdf (inclusive prefix sums of the quantised weights, cells^3 entries)
/// and a uniform point in it. invCells = 1 / cells, computed on the host (the same float on both backends).
NV_HD void importancePoint(const uint64_t* cdf, int cells, float invCells, uint64_t seed, uint64_t step,
  uint64_t index, float x[3])
{
  randomPoint(seed, step, index, x);
  const int n = cells * cells * cells;
  const uint64_t total = cdf[n - 1];
  if ((index & 1u) == 0 || total == 0)
    return;
  const uint64_t h = mix64(mix64(seed * 0x94D049BB133111EBull + step) ^ (index * 0xC2B2AE3D27D4EB4Full) ^ 0x1D8E4E27C47D124Full);
  const uint64_t u = importanceMulHi(h, total); // uniform in [0, total)
  int lo = 0, hi = n - 1;                       // first cell with cdf > u
  while (lo < hi)
  {
    const int mid = (lo + hi) >> 1;
    if (cdf[mid] > u)
      hi = mid;
    else
      lo = mid + 1;
  }
  const int c[3] = { lo % cells, (lo / cells) % cells, lo / (cells * cells) };
  const float below1 = 0.99999994f; // largest float < 1
  for (int d = 0; d < 3; ++d)
  {
    const float v = (static_cast<float>(c[d]) + x[d]) * invCells;
    x[d] = v < below1 ? v : below1;
  }
}

} // namespace nv
