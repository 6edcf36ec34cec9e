#include "ResourceEstimate.h"

#include "Backends.h"
#include "Error.h"
#include "HashGridMath.h"
#include "Model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <fstream>

#include <sys/resource.h>
#include <unistd.h>

namespace nv
{
namespace
{
constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
constexpr uint32_t kMaxInt = static_cast<uint32_t>(std::numeric_limits<int>::max());

// Bytes per parameter held while training on the CPU: the trainer's parameters, gradients and two Adam moments
// (16), the session's model and the filter's base copy (8), the rollback point, its spare buffer and the best network
// (12), the fp16 network the CPU evaluator keeps for inference (2) and the serialized snapshot (2).
constexpr int64_t kCpuHostBytesPerParam = 40;
// On a GPU: fp32 parameters, gradients and Adam moments on the device (16), an fp16 copy and the two-pass scratch of
// the table (4); the host keeps the session's and the filter's copies and the snapshots (24).
constexpr int64_t kGpuDeviceBytesPerParam = 20;
constexpr int64_t kGpuHostBytesPerParam = 24;
} // namespace

int64_t saturatingMul(int64_t a, int64_t b)
{
  if (a <= 0 || b <= 0)
    return 0;
  int64_t r = 0;
  return __builtin_mul_overflow(a, b, &r) ? kMax : r;
}

int64_t saturatingAdd(int64_t a, int64_t b)
{
  int64_t r = 0;
  return __builtin_add_overflow(a, b, &r) ? kMax : r;
}

int64_t physicalMemoryBytes()
{
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0)
    return 0;
  return saturatingMul(pages, page);
}

namespace
{
/// The soft limit of `resource`, INT64_MAX when unlimited or unknown.
int64_t softLimit(int resource)
{
  struct rlimit r;
  if (getrlimit(resource, &r) != 0 || r.rlim_cur == RLIM_INFINITY)
    return kMax;
  return r.rlim_cur >= static_cast<rlim_t>(kMax) ? kMax : static_cast<int64_t>(r.rlim_cur);
}

/// "the process may use at most 16 GB (ulimit -v), 1.2 GB of it already in use"
std::string limitReason(int64_t limit, int64_t used, const char* option)
{
  std::ostringstream s;
  s << "the process may use at most " << formatBytes(limit) << " (ulimit " << option << "), " << formatBytes(used)
    << " of it already in use";
  return s.str();
}
} // namespace

ProcessMemoryLimits processMemoryLimits()
{
  ProcessMemoryLimits l;
  l.addressSpace = softLimit(RLIMIT_AS);
  l.data = softLimit(RLIMIT_DATA);
  // statm: size resident shared text lib data(+stack) dirty, in pages.
  std::ifstream statm("/proc/self/statm");
  int64_t size = 0, resident = 0, shared = 0, text = 0, lib = 0, data = 0;
  const long page = sysconf(_SC_PAGE_SIZE);
  if (statm >> size >> resident >> shared >> text >> lib >> data && page > 0)
  {
    l.addressSpaceUsed = saturatingMul(size, page);
    l.dataUsed = saturatingMul(data, page);
  }
  return l;
}

HostMemoryBudget hostMemoryBudget(const ProcessMemoryLimits* limits)
{
  HostMemoryBudget b;
  b.bytes = kMax;
  const int64_t physical = physicalMemoryBytes();
  if (physical > 0)
  {
    b.bytes = static_cast<int64_t>(static_cast<double>(physical) * kHostMemoryShare);
    std::ostringstream s;
    s << static_cast<int>(kHostMemoryShare * 100.0 + 0.5) << "% of this machine's " << formatBytes(physical);
    b.reason = s.str();
  }
  const ProcessMemoryLimits own = limits ? *limits : processMemoryLimits();
  if (own.addressSpace != kMax)
  {
    const int64_t left = std::max<int64_t>(0, own.addressSpace - own.addressSpaceUsed);
    if (left < b.bytes)
    {
      b.bytes = left;
      b.reason = limitReason(own.addressSpace, own.addressSpaceUsed, "-v");
    }
  }
  if (own.data != kMax)
  {
    const int64_t left = std::max<int64_t>(0, own.data - own.dataUsed);
    if (left < b.bytes)
    {
      b.bytes = left;
      b.reason = limitReason(own.data, own.dataUsed, "-d");
    }
  }
  return b;
}

int64_t hostMemoryLimit()
{
  return hostMemoryBudget().bytes;
}

bool deviceMemoryInfo(int64_t& freeBytes, int64_t& totalBytes, int cudaDevice)
{
  return cudaDeviceMemory(freeBytes, totalBytes, cudaDevice);
}

std::string formatBytes(int64_t bytes)
{
  if (bytes == kMax)
    return "more than 9.2 EB";
  const char* units[] = { "bytes", "kB", "MB", "GB", "TB", "PB", "EB" };
  double v = static_cast<double>(std::max<int64_t>(bytes, 0));
  int u = 0;
  while (v >= 1000.0 && u < 6)
  {
    v /= 1000.0;
    ++u;
  }
  std::ostringstream s;
  if (u == 0)
    s << bytes << " bytes";
  else
  {
    s.precision(v < 10.0 ? 2 : 3);
    s << v << " " << units[u];
  }
  return s.str();
}

int64_t parameterCount(const ModelConfig& config)
{
  validate(config);
  const GridLayout layout = makeGridLayout(config.encoding);
  const int64_t mlp = static_cast<int64_t>(mlpParameterCount(config));
  return saturatingAdd(saturatingMul(static_cast<int64_t>(layout.totalEntries), layout.features), mlp);
}

MemoryEstimate trainingMemory(const ModelConfig& model, const TrainConfig& train, Device device, int64_t volumeBytes)
{
  const int64_t params = parameterCount(model);
  const int64_t batch = std::max(train.batchSize, 1);
  const int64_t d = model.encoding.outputDims();
  const int64_t wl = int64_t(model.network.width) * model.network.hiddenLayers;
  MemoryEstimate e;
  std::ostringstream s;
  s << params << " parameters (" << formatBytes(saturatingMul(params, 4)) << " each copy)";
  if (device == Device::Cuda)
  {
    // Per sample on the device: position and target (16), encodings and their gradients in fp16 (4 D), activations
    // kept for the backward pass in fp16 (4 W L).
    const int64_t batchBytes = saturatingMul(batch, 16 + 4 * d + 4 * wl);
    e.deviceBytes = saturatingAdd(saturatingAdd(saturatingMul(params, kGpuDeviceBytesPerParam), batchBytes),
      std::max<int64_t>(volumeBytes, 0));
    // The host samples batches for the host-sampled strategy (two batches of positions and targets in flight).
    e.hostBytes = saturatingAdd(saturatingMul(params, kGpuHostBytesPerParam), saturatingMul(batch, 32));
    s << ", batch of " << batch << " samples " << formatBytes(batchBytes) << " on the GPU";
    if (volumeBytes > 0)
      s << ", volume " << formatBytes(volumeBytes) << " on the GPU";
  }
  else
  {
    // Per sample on the host: position (12), target (4), valid flag (1), encoding gradients (4 D).
    const int64_t batchBytes = saturatingMul(batch, 17 + 4 * d);
    e.hostBytes = saturatingAdd(saturatingMul(params, kCpuHostBytesPerParam), batchBytes);
    s << ", batch of " << batch << " samples " << formatBytes(batchBytes);
  }
  e.detail = s.str();
  return e;
}

MemoryEstimate decodeGridMemory(const int64_t dims[3], Device device)
{
  const int64_t samples = saturatingMul(saturatingMul(dims[0], dims[1]), dims[2]);
  MemoryEstimate e;
  std::ostringstream s;
  s << dims[0] << " x " << dims[1] << " x " << dims[2] << " samples";
  if (device == Device::Cuda)
  {
    e.deviceBytes = saturatingMul(samples, 8); // the linear grid and the 3-D texture, float each
  }
  else
  {
    // The float grid, the grid it replaces (kept until it is complete) and the coarse preview shown while it
    // decodes (dims / 4 per axis: 1/64 of it).
    e.hostBytes = saturatingAdd(saturatingMul(samples, 8), saturatingMul(samples / 64, 4));
  }
  e.detail = s.str();
  return e;
}

void checkMemory(const MemoryEstimate& estimate, const std::string& what, const std::string& advice,
  int64_t deviceFree, int64_t hostLimit)
{
  HostMemoryBudget budget;
  if (hostLimit >= 0)
    budget.bytes = hostLimit;
  else
    budget = hostMemoryBudget();
  if (estimate.hostBytes > budget.bytes)
  {
    std::ostringstream s;
    s << what << " needs about " << formatBytes(estimate.hostBytes) << " of host memory (" << estimate.detail
      << "); the limit is " << formatBytes(budget.bytes);
    if (!budget.reason.empty())
      s << " (" << budget.reason << ")";
    s << ". " << advice << ".";
    throw Error(s.str());
  }
  if (deviceFree >= 0)
  {
    const int64_t deviceLimit = static_cast<int64_t>(static_cast<double>(deviceFree) * kDeviceMemoryShare);
    if (estimate.deviceBytes > deviceLimit)
    {
      std::ostringstream s;
      s << what << " needs about " << formatBytes(estimate.deviceBytes) << " of GPU memory (" << estimate.detail
        << "); the limit is " << formatBytes(deviceLimit) << " (" << static_cast<int>(kDeviceMemoryShare * 100.0 + 0.5)
        << "% of the " << formatBytes(deviceFree) << " free on the GPU). " << advice << ".";
      throw Error(s.str());
    }
  }
}

bool clampGrid(const int64_t dims[3], int64_t maxSamples, int64_t out[3])
{
  for (int a = 0; a < 3; ++a)
    out[a] = std::max<int64_t>(1, dims[a]);
  maxSamples = std::max<int64_t>(1, maxSamples);
  if (saturatingMul(saturatingMul(out[0], out[1]), out[2]) <= maxSamples)
    return false;
  // One factor for every axis (the grid keeps its proportions), then down by single samples where rounding left it
  // above the limit.
  const double samples = static_cast<double>(out[0]) * static_cast<double>(out[1]) * static_cast<double>(out[2]);
  const double f = std::cbrt(static_cast<double>(maxSamples) / samples);
  for (int a = 0; a < 3; ++a)
    out[a] = std::max<int64_t>(1, static_cast<int64_t>(std::floor(static_cast<double>(out[a]) * f)));
  while (saturatingMul(saturatingMul(out[0], out[1]), out[2]) > maxSamples)
  {
    int a = 0;
    for (int k = 1; k < 3; ++k)
      if (out[k] > out[a])
        a = k;
    if (out[a] <= 1)
      break;
    --out[a];
  }
  return true;
}

int resolvedSamplesPerAxis(const EncodingConfig& encoding)
{
  const GridLayout layout = makeGridLayout(encoding); // validates it
  return static_cast<int>(std::min<uint32_t>(layout.level[layout.levels - 1].res, kMaxInt));
}

std::string fitDecodeGrid(const SourceInfo& src, Device device, const int asked[3], int used[3], int resolved)
{
  const bool own = asked[0] > 0 && asked[1] > 0 && asked[2] > 0;
  int64_t dims[3], clamped[3];
  for (int a = 0; a < 3; ++a)
    dims[a] = std::max<int64_t>(1, own ? asked[a] : src.dims[a]);
  std::ostringstream s;
  bool clamp = false;
  if (own && resolved > 0)
  {
    // Much finer than the finest level only interpolates between its vertices (the source's own dims are kept).
    bool finer = false;
    const int64_t most = saturatingMul(resolved, kDecodeOversampling);
    for (int a = 0; a < 3; ++a)
    {
      const int64_t cap = std::max<int64_t>(most, src.dims[a]);
      if (dims[a] > cap)
      {
        dims[a] = cap;
        finer = true;
      }
    }
    if (finer)
      s << "finer than the network resolves (its finest level has " << resolved << " samples per axis, decoded at most "
        << kDecodeOversampling << "x as fine); ";
    clamp = finer;
  }
  bool coarse = false;
  for (int a = 0; a < 3; ++a)
    if (dims[a] > kMaxDecodeResolution)
    {
      dims[a] = kMaxDecodeResolution;
      coarse = true;
    }
  if (coarse)
    s << "more than " << kMaxDecodeResolution << " samples per axis; ";
  clamp = clamp || coarse;
  const bool gpu = device == Device::Cuda;
  const MemoryEstimate one = decodeGridMemory(dims, device);
  int64_t maxSamples = kMaxDecodeGridSamples;
  const int64_t samples = dims[0] * dims[1] * dims[2];
  const double bytesPerSample =
    static_cast<double>(gpu ? one.deviceBytes : one.hostBytes) / static_cast<double>(std::max<int64_t>(samples, 1));
  int64_t freeBytes = -1, totalBytes = 0;
  HostMemoryBudget budget;
  if (!gpu)
    budget = hostMemoryBudget();
  else if (deviceMemoryInfo(freeBytes, totalBytes))
    budget.bytes = static_cast<int64_t>(static_cast<double>(freeBytes) * kDeviceMemoryShare);
  else
    budget.bytes = -1;
  if (budget.bytes >= 0 && bytesPerSample > 0.0)
    maxSamples = std::min<int64_t>(maxSamples, static_cast<int64_t>(static_cast<double>(budget.bytes) / bytesPerSample));
  if (clampGrid(dims, maxSamples, clamped))
  {
    s << "a grid of " << dims[0] << " x " << dims[1] << " x " << dims[2] << " samples needs about "
      << formatBytes(gpu ? one.deviceBytes : one.hostBytes) << " of " << (gpu ? "GPU" : "host")
      << " memory, the limit is " << formatBytes(budget.bytes);
    if (!budget.reason.empty())
      s << " (" << budget.reason << ")";
    s << " and at most 2^31 samples; ";
    std::copy(clamped, clamped + 3, dims);
    clamp = true;
  }
  for (int a = 0; a < 3; ++a)
    used[a] = clamp || own ? static_cast<int>(dims[a]) : 0;
  return s.str();
}

} // namespace nv
