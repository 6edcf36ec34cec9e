#include "CpuInference.h"

#include "Core/Model.h"
#include "CpuHashGrid.h"
#include "ThreadPool.h"

#include <algorithm>

namespace nv
{

CpuInference::CpuInference(const Model& m)
  : Network(m)
  , Mlp(m)
  , TransposedWeights(Mlp.paramCount())
{
  Mlp.transpose(m.params().data() + m.encodingParamCount(), TransposedWeights.data());
}

CpuInference::Scratch CpuInference::scratch() const
{
  Scratch s;
  s.enc.resize(static_cast<size_t>(kTile) * Network.config().encoding.outputDims());
  s.acts.resize(static_cast<size_t>(kTile) * Mlp.width() * Mlp.hidden());
  return s;
}

void CpuInference::evaluate(const float* xyz, int n, float* out, Scratch& s) const
{
  CpuHashGrid::encode(Network.layout(), Network.params().data(), xyz, n, s.enc.data());
  Mlp.forward(TransposedWeights.data(), s.enc.data(), n, s.acts.data(), out);
}

void CpuInference::inferPoints(ThreadPool& pool, const float* xyz, int64_t n, float* out) const
{
  pool.parallelFor(n, [&](int64_t b, int64_t e, int) {
    Scratch s = scratch();
    for (int64_t t = b; t < e; t += kTile)
      evaluate(xyz + 3 * t, static_cast<int>(std::min<int64_t>(kTile, e - t)), out + t, s);
  });
}

void CpuInference::decodeGrid(ThreadPool& pool, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1,
  float* out) const
{
  const int64_t rows = (z1 - z0) * ny;
  pool.parallelFor(rows, [&](int64_t b, int64_t e, int) {
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
        evaluate(xyz.data(), m, row + x0, s);
      }
    }
  });
}

} // namespace nv
