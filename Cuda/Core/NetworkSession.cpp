#include "NetworkSession.h"

#include "Backends.h"
#include "Error.h"

#include <vector>

namespace nv
{

std::unique_ptr<NetworkSession> NetworkSession::create(Device device, const Model& model,
  const SessionOptions& options, std::string* message)
{
  validate(model.config());
  NV_CHECK(model.paramCount() > 0, "model has no parameters");
  NV_CHECK(options.threads >= 0 && options.threads <= 4096, "thread count must be in 0..4096");
  NV_CHECK(options.cudaDevice >= -1, "SessionOptions::cudaDevice must be -1 (the current device) or an ordinal");
  if (resolveDevice(device, message, options.cudaDevice) == Device::Cuda)
    return createCudaSession(model, options);
  return createCpuSession(model, options);
}

TrainConfig trainerConfig(const VolumeView& volume, const TrainConfig& config, const SessionOptions& options)
{
  validate(config);
  NV_CHECK(volume.data != nullptr && volume.count() > 0, "empty source volume");
  TrainConfig c = config;
  if (c.threads == 0)
    c.threads = options.threads;
  return c;
}

TrainConfig trainerConfig(const TrainingPoints& points, const TrainConfig& config, const SessionOptions& options)
{
  validate(config);
  NV_CHECK(points.count > 0 && points.xyz != nullptr && points.values != nullptr, "empty bank of training points");
  NV_CHECK(points.count <= (int64_t(1) << 31), "a bank of training points holds at most 2^31 points");
  TrainConfig c = config;
  if (c.threads == 0)
    c.threads = options.threads;
  return c;
}

TrainConfig trainerConfig(const BatchSource&, const TrainConfig& config, const SessionOptions& options)
{
  validate(config);
  TrainConfig c = config;
  c.importanceGrid = 0; // error-guided sampling needs the whole field at hand
  if (c.threads == 0)
    c.threads = options.threads;
  return c;
}

std::shared_ptr<const ErrorCorrections> sharedCorrections(const Model& model)
{
  return model.corrections.enabled() ? std::make_shared<const ErrorCorrections>(model.corrections) : nullptr;
}

namespace
{
template <typename T>
void decodeValues(NetworkSession& s, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, T* out)
{
  NV_CHECK(nx >= 1 && ny >= 1 && nz >= 1 && z0 >= 0 && z0 <= z1 && z1 <= nz, "decodeGridValues: invalid grid");
  const int64_t n = nx * ny * (z1 - z0);
  std::vector<float> tmp;
  float* norm = reinterpret_cast<float*>(out);
  if (sizeof(T) != sizeof(float))
  {
    tmp.resize(static_cast<size_t>(n));
    norm = tmp.data();
  }
  s.decodeGrid(nx, ny, nz, z0, z1, norm, Memory::Host);
  const Model& model = s.model();
  const ValueRange range = model.valueRange();
  for (int64_t i = 0; i < n; ++i)
    out[i] = storedValue<T>(range.denormalize(static_cast<double>(norm[i]))); // never inf in float
  // The error-bounded mode: on the source's own grid, the listed samples are corrected to within the bound.
  const int64_t* dims = model.source.dims;
  const std::shared_ptr<const ErrorCorrections> corrections = s.errorCorrections();
  if (corrections && nx == dims[0] && ny == dims[1] && nz == dims[2])
    applyCorrections(*corrections, z0 * nx * ny, n, out);
}
} // namespace

void decodeGridValues(NetworkSession& s, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out)
{
  decodeValues(s, nx, ny, nz, z0, z1, out);
}

void decodeGridValues(NetworkSession& s, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, double* out)
{
  decodeValues(s, nx, ny, nz, z0, z1, out);
}

ErrorStats compareToSource(NetworkSession& s, const VolumeView& volume)
{
  const int64_t nx = volume.dims[0], ny = volume.dims[1], nz = volume.dims[2];
  std::vector<double> decoded(static_cast<size_t>(volume.count()));
  decodeGridValues(s, nx, ny, nz, 0, nz, decoded.data());
  return compareDecoded(decoded.data(), volume, s.model().source.valueMin, s.model().source.valueMax, 0);
}

} // namespace nv
