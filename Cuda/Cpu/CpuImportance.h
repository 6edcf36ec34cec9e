// NeuralVolume engine: the CPU trainer's importance grid (Core/ImportanceGrid.h): per-worker fixed-point error sums
// of the training samples, folded into the cell weights and the integer CDF every kImportanceInterval steps.
#pragma once

#include "Core/ImportanceGrid.h"

#include <cstdint>
#include <vector>

namespace nv
{

class CpuImportance
{
public:
  /// Per-worker error sums since the last refresh.
  struct Sums
  {
    std::vector<uint64_t> error;
    std::vector<uint32_t> count;
  };

  CpuImportance() = default;

  /// cells per axis (0: off), one Sums per worker.
  void reset(int cells, int workers)
  {
    Cells = cells;
    if (cells <= 0)
      return;
    InvCells = 1.0f / static_cast<float>(cells);
    const size_t n = static_cast<size_t>(cells) * cells * cells;
    Weights.assign(n, -1.0f);
    Cdf.assign(n, 0);
    Work.resize(static_cast<size_t>(workers));
    for (Sums& s : Work)
    {
      s.error.assign(n, 0);
      s.count.assign(n, 0);
    }
  }

  bool enabled() const { return Cells > 0; }
  int cells() const { return Cells; }
  float invCells() const { return InvCells; }
  const uint64_t* cdf() const { return Cdf.data(); }
  const std::vector<float>& weights() const { return Weights; }

  /// Training point `index` of step `step` (uniform when off).
  void point(uint64_t seed, uint64_t step, uint64_t index, float x[3]) const
  {
    if (Cells > 0)
      importancePoint(Cdf.data(), Cells, InvCells, seed, step, index, x);
    else
      randomPoint(seed, step, index, x);
  }

  /// Worker w: a sample at x with normalised absolute error e.
  void add(int w, const float* x, float e)
  {
    const int c = importanceCell(x, Cells);
    Sums& s = Work[static_cast<size_t>(w)];
    s.error[static_cast<size_t>(c)] += importanceFixedError(e);
    s.count[static_cast<size_t>(c)] += 1;
  }

  /// Folds the sums into the weights and rebuilds the CDF (integer sums: independent of the worker split).
  void refresh()
  {
    uint64_t prefix = 0;
    for (size_t c = 0; c < Weights.size(); ++c)
    {
      uint64_t sum = 0;
      uint32_t count = 0;
      for (Sums& s : Work)
      {
        sum += s.error[c];
        count += s.count[c];
        s.error[c] = 0;
        s.count[c] = 0;
      }
      Weights[c] = importanceUpdate(Weights[c], sum, count);
      prefix += importanceQuantize(Weights[c]);
      Cdf[c] = prefix;
    }
  }

  /// Tests: set the weights directly and rebuild the CDF.
  void setWeights(const std::vector<float>& w)
  {
    uint64_t prefix = 0;
    for (size_t c = 0; c < Weights.size() && c < w.size(); ++c)
    {
      Weights[c] = w[c];
      prefix += importanceQuantize(w[c]);
      Cdf[c] = prefix;
    }
  }

private:
  int Cells = 0;
  float InvCells = 0.0f;
  std::vector<float> Weights;
  std::vector<uint64_t> Cdf;
  std::vector<Sums> Work;
};

} // namespace nv
