#include "CpuInference.h"

#include "Core/Model.h"
#include "CpuHashGrid.h"
#include "CpuMlp.h"
#include "ThreadPool.h"

#include <algorithm>
#include <vector>

namespace nv
{
namespace
{
constexpr int kTile = 64;

struct Evaluator
{
  explicit Evaluator(const Model& m)
    : model(m)
    , mlp(m)
    , WT(mlp.paramCount())
  {
    mlp.transpose(m.params().data() + m.encodingParamCount(), WT.data());
  }
  // Evaluate n (<= kTile) points.
  void run(const float* xyz, int n, float* out, std::vector<float>& enc, std::vector<float>& acts) const
  {
    CpuHashGrid::encode(model.layout(), model.params().data(), xyz, n, enc.data());
    mlp.forward(WT.data(), enc.data(), n, acts.data(), out);
  }
  std::vector<float> encBuffer() const
  {
    return std::vector<float>(static_cast<size_t>(kTile) * model.config().encoding.outputDims());
  }
  std::vector<float> actBuffer() const
  {
    return std::vector<float>(static_cast<size_t>(kTile) * mlp.width() * mlp.hidden());
  }
  const Model& model;
  CpuMlp mlp;
  std::vector<float> WT;
};
} // namespace

void cpuInferPoints(const Model& model, const float* xyz, int64_t n, float* out, int threads)
{
  const Evaluator ev(model);
  ThreadPool pool(threads);
  pool.parallelFor(n, [&](int64_t b, int64_t e, int) {
    std::vector<float> enc = ev.encBuffer(), acts = ev.actBuffer();
    for (int64_t t = b; t < e; t += kTile)
    {
      ev.run(xyz + 3 * t, static_cast<int>(std::min<int64_t>(kTile, e - t)), out + t, enc, acts);
    }
  });
}

void cpuDecodeGrid(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out,
  int threads)
{
  const Evaluator ev(model);
  ThreadPool pool(threads);
  const int64_t rows = (z1 - z0) * ny;
  pool.parallelFor(rows, [&](int64_t b, int64_t e, int) {
    std::vector<float> enc = ev.encBuffer(), acts = ev.actBuffer();
    std::vector<float> xyz(3 * kTile);
    for (int64_t r = b; r < e; ++r)
    {
      const int64_t z = z0 + r / ny, y = r % ny;
      const float fy = gridCoordinate(y, ny), fz = gridCoordinate(z, nz);
      float* row = out + r * nx;
      for (int64_t x0 = 0; x0 < nx; x0 += kTile)
      {
        const int m = static_cast<int>(std::min<int64_t>(kTile, nx - x0));
        for (int k = 0; k < m; ++k)
        {
          xyz[3 * k] = gridCoordinate(x0 + k, nx);
          xyz[3 * k + 1] = fy;
          xyz[3 * k + 2] = fz;
        }
        ev.run(xyz.data(), m, row + x0, enc, acts);
      }
    }
  });
}

} // namespace nv
