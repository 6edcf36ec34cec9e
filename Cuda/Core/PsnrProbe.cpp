// NeuralVolume engine: the PSNR probe of a training run (PsnrProbe.h).
#include "PsnrProbe.h"

#include "ValueRange.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace nv
{

double psnrFromMse(double mse)
{
  return mse > 0.0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
}

PsnrProbe::PsnrProbe(const VolumeView& view, uint64_t seed, int64_t maxSamples)
{
  const int64_t n = view.count();
  const ValueRange range(view.valueMin, view.valueMax); // as the samplers normalise (ValueRange.h)
  std::mt19937_64 rng(seed ^ 0x5EED5EEDull);
  std::uniform_int_distribution<int64_t> pick(0, std::max<int64_t>(n - 1, 0));
  const int64_t want = std::min(n, maxSamples);
  const int64_t maxTries = want * 4 + 16;
  Coords.reserve(static_cast<size_t>(want) * 3);
  Expected.reserve(static_cast<size_t>(want));
  for (int64_t t = 0; t < maxTries && static_cast<int64_t>(Expected.size()) < want; ++t)
  {
    // Every voxel when the volume is small, else a random subset.
    const int64_t i = n <= maxSamples ? t : pick(rng);
    if (i >= n)
    {
      break;
    }
    const double v = view.at(i);
    if (!std::isfinite(v))
    {
      continue;
    }
    const int64_t x = i % view.dims[0];
    const int64_t y = (i / view.dims[0]) % view.dims[1];
    const int64_t z = i / (view.dims[0] * view.dims[1]);
    const int64_t idx[3] = { x, y, z };
    for (int d = 0; d < 3; ++d)
    {
      const int64_t m = view.dims[d];
      Coords.push_back(m > 1 ? static_cast<float>(static_cast<double>(idx[d]) / (m - 1)) : 0.5f);
    }
    Expected.push_back(static_cast<float>(range.normalize(v)));
  }
}

PsnrProbe::PsnrProbe(const std::vector<float>& xyz, const std::vector<float>& values, int64_t maxSamples)
{
  const int64_t n = static_cast<int64_t>(values.size());
  const int64_t stride = std::max<int64_t>(1, (n + maxSamples - 1) / std::max<int64_t>(maxSamples, 1));
  for (int64_t i = 0; i < n; i += stride)
  {
    if (!std::isfinite(values[size_t(i)]))
      continue;
    Coords.insert(Coords.end(), xyz.begin() + 3 * i, xyz.begin() + 3 * i + 3);
    Expected.push_back(values[size_t(i)]);
  }
}

double PsnrProbe::estimate(NetworkSession& session) const
{
  const int64_t n = static_cast<int64_t>(Expected.size());
  if (n == 0)
  {
    return std::numeric_limits<double>::quiet_NaN();
  }
  std::vector<float> out(static_cast<size_t>(n));
  session.inferPoints(Coords.data(), n, out.data(), Memory::Host);
  double se = 0.0;
  for (int64_t i = 0; i < n; ++i)
  {
    const double d = static_cast<double>(out[i]) - Expected[i];
    se += d * d;
  }
  return psnrFromMse(se / static_cast<double>(n));
}

} // namespace nv
