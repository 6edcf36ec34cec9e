#include "CpuBatchNetwork.h"

#include "Core/Error.h"
#include "Core/Model.h"
#include "CpuHashGrid.h"
#include "CpuInference.h"
#include "ThreadPool.h"

#include <algorithm>

namespace nv
{

CpuBatchNetwork::CpuBatchNetwork(const Model& model)
  : M(model)
  , Mlp(model)
  , WT(Mlp.paramCount())
{
  NV_CHECK(model.paramCount() == model.encodingParamCount() + model.mlpParamCount(), "the model has no parameters");
  Mlp.transpose(model.params().data() + model.encodingParamCount(), WT.data());
}

CpuBatchNetwork::Scratch CpuBatchNetwork::scratch() const
{
  Scratch s;
  s.enc.resize(static_cast<size_t>(kTile) * M.config().encoding.outputDims());
  s.acts.resize(static_cast<size_t>(kTile) * Mlp.width() * Mlp.hidden());
  return s;
}

void CpuBatchNetwork::evaluateTile(const float* xyz, int n, float* out, Scratch& s) const
{
  CpuHashGrid::encode(M.layout(), M.params().data(), xyz, n, s.enc.data());
  Mlp.forward(WT.data(), s.enc.data(), n, s.acts.data(), out);
}

void CpuBatchNetwork::evaluate(ThreadPool& pool, const float* xyz, int64_t n, float* out) const
{
  // Chunks of 16 tiles: small enough to balance, large enough that the scratch allocation does not matter.
  pool.parallelChunks(n, 16 * kTile, [&](int64_t b, int64_t e, int) {
    Scratch s = scratch();
    for (int64_t t = b; t < e; t += kTile)
      evaluateTile(xyz + 3 * t, static_cast<int>(std::min<int64_t>(kTile, e - t)), out + t, s);
  });
}

bool CpuBatchNetwork::decodeSlices(ThreadPool& pool, const int64_t dims[3], int64_t z0, int64_t z1, float* out,
  const std::atomic<bool>* cancel) const
{
  const int64_t nx = dims[0], ny = dims[1], nz = dims[2];
  const int64_t rows = (z1 - z0) * ny;
  const int64_t rowsPerChunk = std::max<int64_t>(1, 4096 / std::max<int64_t>(1, nx));
  std::atomic<bool> stopped(false);
  pool.parallelChunks(rows, rowsPerChunk, [&](int64_t b, int64_t e, int) {
    if (cancel && cancel->load(std::memory_order_relaxed))
    {
      stopped = true;
      return;
    }
    Scratch s = scratch();
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
        evaluateTile(xyz.data(), m, row + x0, s);
      }
    }
  });
  return !stopped;
}

} // namespace nv
