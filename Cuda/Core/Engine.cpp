#include "Engine.h"

#include "Cpu/CpuInference.h"
#include "Cpu/CpuTrainer.h"
#include "Cpu/ThreadPool.h"
#include "Error.h"
#if defined(NV_WITH_CUDA)
#include "Gpu/GpuEngine.h"
#endif

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

namespace nv
{

bool cudaAvailable(std::string* why)
{
#if defined(NV_WITH_CUDA)
  return gpu::deviceUsable(why);
#else
  if (why)
  {
    *why = "this build of NeuralVolume has no CUDA support (no CUDA compiler at build time)";
  }
  return false;
#endif
}

Device resolveDevice(Device requested, std::string* message)
{
  std::string why;
  switch (requested)
  {
    case Device::Cpu:
      return Device::Cpu;
    case Device::Cuda:
      if (!cudaAvailable(&why))
      {
        NV_THROW("CUDA device requested but not usable: " + why);
      }
      return Device::Cuda;
    case Device::Auto:
      if (cudaAvailable(&why))
      {
        return Device::Cuda;
      }
      if (message)
      {
        *message = "no usable GPU (" + why + "); training on the CPU";
      }
      return Device::Cpu;
  }
  return Device::Cpu;
}

std::unique_ptr<Trainer> createTrainer(Device device, const Model& model, const VolumeView& volume,
  const TrainConfig& config)
{
  validate(model.config());
  validate(config);
  NV_CHECK(volume.data != nullptr && volume.count() > 0, "empty source volume");
  NV_CHECK(model.paramCount() > 0, "model has no parameters");
  const Device d = resolveDevice(device);
#if defined(NV_WITH_CUDA)
  if (d == Device::Cuda)
  {
    return gpu::createTrainer(model, volume, config);
  }
#endif
  (void)d;
  return std::unique_ptr<Trainer>(new CpuTrainer(model, volume, config));
}

void inferPoints(const Model& model, const float* xyz, int64_t n, float* out, Device device, int threads)
{
  NV_CHECK(n >= 0 && (n == 0 || (xyz && out)), "inferPoints: invalid arguments");
  if (n == 0)
    return;
#if defined(NV_WITH_CUDA)
  if (resolveDevice(device) == Device::Cuda)
  {
    gpu::inferPoints(model, xyz, n, out);
    return;
  }
#else
  resolveDevice(device);
#endif
  cpuInferPoints(model, xyz, n, out, threads);
}

void decodeGridNormalized(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out,
  Device device, int threads)
{
  NV_CHECK(nx >= 1 && ny >= 1 && nz >= 1, "decodeGrid: grid dimensions must be >= 1");
  NV_CHECK(z0 >= 0 && z0 <= z1 && z1 <= nz, "decodeGrid: invalid slice range");
  NV_CHECK(out != nullptr || z0 == z1, "decodeGrid: null output");
  if (z0 == z1)
    return;
#if defined(NV_WITH_CUDA)
  if (resolveDevice(device) == Device::Cuda)
  {
    gpu::decodeGrid(model, nx, ny, nz, z0, z1, out);
    return;
  }
#else
  resolveDevice(device);
#endif
  cpuDecodeGrid(model, nx, ny, nz, z0, z1, out, threads);
}

namespace
{
template <typename T>
void decodeDenormalized(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, T* out,
  Device device, int threads)
{
  const int64_t n = (z1 - z0) * ny * nx;
  std::vector<float> tmp;
  float* norm = reinterpret_cast<float*>(out);
  if (!std::is_same<T, float>::value)
  {
    tmp.resize(static_cast<size_t>(n));
    norm = tmp.data();
  }
  decodeGridNormalized(model, nx, ny, nz, z0, z1, norm, device, threads);
  const double lo = model.source.valueMin, range = model.source.valueMax - model.source.valueMin;
  ThreadPool pool(threads);
  pool.parallelFor(n, [&](int64_t b, int64_t e, int) {
    for (int64_t i = b; i < e; ++i)
    {
      out[i] = static_cast<T>(lo + range * static_cast<double>(norm[i]));
    }
  });
}

template <typename T>
ErrorStats compareDecodedT(const T* decoded, const VolumeView& v, double valueMin, double valueMax, int threads)
{
  ErrorStats r;
  const double range = valueMax - valueMin;
  const double inv = range > 0.0 ? 1.0 / range : 0.0;
  ThreadPool pool(threads);
  std::vector<double> se(pool.size(), 0.0), mx(pool.size(), 0.0);
  std::vector<int64_t> cnt(pool.size(), 0);
  pool.parallelFor(v.count(), [&](int64_t b, int64_t e, int w) {
    for (int64_t i = b; i < e; ++i)
    {
      const double x = v.at(i);
      if (!std::isfinite(x))
        continue;
      // Difference in normalised units first: stays finite for huge ranges.
      const double dn = range > 0.0 ? (static_cast<double>(decoded[i]) - valueMin) * inv - (x - valueMin) * inv
                                    : static_cast<double>(decoded[i]) - x;
      se[w] += dn * dn;
      mx[w] = std::max(mx[w], std::fabs(range > 0.0 ? dn * range : dn));
      ++cnt[w];
    }
  });
  double sum = 0.0;
  for (int w = 0; w < pool.size(); ++w)
  {
    sum += se[w];
    r.maxAbsError = std::max(r.maxAbsError, mx[w]);
    r.count += cnt[w];
  }
  r.mse = r.count > 0 ? sum / static_cast<double>(r.count) : 0.0;
  r.psnr = r.mse > 0.0 ? 10.0 * std::log10(1.0 / r.mse) : std::numeric_limits<double>::infinity();
  return r;
}
} // namespace

void decodeGrid(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out,
  Device device, int threads)
{
  decodeDenormalized(model, nx, ny, nz, z0, z1, out, device, threads);
}

void decodeGrid(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, double* out,
  Device device, int threads)
{
  decodeDenormalized(model, nx, ny, nz, z0, z1, out, device, threads);
}

ErrorStats compareDecoded(const float* decoded, const VolumeView& v, double valueMin, double valueMax, int threads)
{
  return compareDecodedT(decoded, v, valueMin, valueMax, threads);
}

ErrorStats compareDecoded(const double* decoded, const VolumeView& v, double valueMin, double valueMax, int threads)
{
  return compareDecodedT(decoded, v, valueMin, valueMax, threads);
}

ErrorStats compareToSource(const Model& model, const VolumeView& volume, Device device, int threads)
{
  const int64_t nx = volume.dims[0], ny = volume.dims[1], nz = volume.dims[2];
  std::vector<double> decoded(static_cast<size_t>(volume.count()));
  decodeGrid(model, nx, ny, nz, 0, nz, decoded.data(), device, threads);
  return compareDecoded(decoded.data(), volume, model.source.valueMin, model.source.valueMax, threads);
}

} // namespace nv
