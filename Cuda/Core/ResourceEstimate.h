// NeuralVolume engine: memory estimates made before anything large is allocated, and the limits they are held to.
//
// A user can type a hash table, a batch, an output or a decode resolution that the machine cannot hold. Allocating it
// ends in std::bad_alloc (or the kernel's OOM killer) deep inside a step or a render; these functions let the callers
// (the Neural Compress filter, the Neural Volume mapper) compare an estimate with the machine first and refuse with
// the figures, or clamp a render setting:
//   nv::MemoryEstimate e = nv::trainingMemory(config, train, device);
//   nv::checkMemory(e, "training", "lower Log2TableSize or BatchSize");   // nv::Error with estimate and limit
//
// Estimates are upper bounds of what the engine holds at once (the CPU and CUDA backends' buffers, the copies the
// filter keeps for rollback and the best network), not exact figures. Sizes saturate at INT64_MAX instead of
// overflowing, so absurd requests (dims of 2^31 per axis) still compare as "too large".
#pragma once

#include "Config.h"

#include <cstdint>
#include <limits>
#include <string>

namespace nv
{

/// Share of the physical memory that one request may use (the rest is left to the system, ParaView and the input).
constexpr double kHostMemoryShare = 0.8;
/// Share of the free GPU memory that one request may use (the driver and other streams keep the rest).
constexpr double kDeviceMemoryShare = 0.9;

/// Bytes of physical memory of this machine (sysconf); 0 when unknown.
int64_t physicalMemoryBytes();

/// What this process may still allocate on the host, and which limit says so.
struct HostMemoryBudget
{
  int64_t bytes = 0;  ///< INT64_MAX when nothing is known
  std::string reason; ///< "80% of this machine's 23 GB", "the process may use at most 16 GB (ulimit -v), 1.2 GB of
                      ///< it already in use"; "" when nothing is known
};

/// The process's address-space and data-segment limits (getrlimit RLIMIT_AS, RLIMIT_DATA; INT64_MAX when unlimited)
/// and what it already uses of them (/proc/self/statm: the total program size, which RLIMIT_AS is checked against, and
/// the data + stack size, which RLIMIT_DATA is checked against; resident figures such as getrusage's maxrss do not
/// count reserved but untouched mappings, which the kernel refuses against the limit all the same).
struct ProcessMemoryLimits
{
  int64_t addressSpace = std::numeric_limits<int64_t>::max(), addressSpaceUsed = 0;
  int64_t data = std::numeric_limits<int64_t>::max(), dataUsed = 0;
};
ProcessMemoryLimits processMemoryLimits();

/// The smaller of kHostMemoryShare of the physical memory and what the process's limits leave
/// (processMemoryLimits: limit minus use), with its reason. `limits` null: the process's own.
HostMemoryBudget hostMemoryBudget(const ProcessMemoryLimits* limits = nullptr);
/// hostMemoryBudget().bytes; INT64_MAX when unknown (nothing is refused then).
int64_t hostMemoryLimit();
/// Free and total bytes of CUDA device `cudaDevice` (-1: the current one). False in a build without CUDA or without
/// a usable GPU; call it only where a GPU session exists (it creates the CUDA context otherwise).
bool deviceMemoryInfo(int64_t& freeBytes, int64_t& totalBytes, int cudaDevice = -1);

/// a * b, or INT64_MAX when it overflows (negative factors count as 0).
int64_t saturatingMul(int64_t a, int64_t b);
/// a + b, or INT64_MAX when it overflows.
int64_t saturatingAdd(int64_t a, int64_t b);
/// "9.4 GB", "512 MB", "12 kB" (decimal units, 2 significant decimals at most).
std::string formatBytes(int64_t bytes);

/// Parameters of a model of this configuration (hash-table entries x features + MLP weights), without allocating it.
/// Throws nv::Error for an invalid configuration (validate()).
int64_t parameterCount(const ModelConfig& config);

struct MemoryEstimate
{
  int64_t hostBytes = 0;
  int64_t deviceBytes = 0; ///< 0 for the CPU
  std::string detail;      ///< what the bytes are, e.g. "hash table and MLP 2.4 GB x 11 copies, batch 4.6 GB"
};

/// Training on `device` (Cpu or Cuda): the parameters with their gradients, Adam moments, the session's copies and
/// the rollback / best-network snapshots, plus the batch buffers (positions, targets, encoding gradients) and, on a
/// GPU, the activations and the volume when it is uploaded (`volumeBytes`, 0 when it stays on the host).
MemoryEstimate trainingMemory(const ModelConfig& model, const TrainConfig& train, Device device,
  int64_t volumeBytes = 0);

/// A decode grid of dims[0] x dims[1] x dims[2] float samples held by a renderer on `device` (the CPU renderer's grid,
/// the grid it replaces and its coarse preview; the GPU renderer's grid and texture in device memory).
MemoryEstimate decodeGridMemory(const int64_t dims[3], Device device);

/// Throws nv::Error when `estimate` exceeds the host limit (or, when `deviceFree` >= 0, kDeviceMemoryShare of
/// it): "<what> needs about 9.4 GB of host memory (<detail>); the limit is 18 GB (80% of this machine's 23 GB).
/// <advice>." or "...; the limit is 6.1 GB (the process may use at most 8.6 GB (ulimit -v), 2.5 GB of it already in
/// use). <advice>." `hostLimit` < 0: hostMemoryBudget().
void checkMemory(const MemoryEstimate& estimate, const std::string& what, const std::string& advice,
  int64_t deviceFree = -1, int64_t hostLimit = -1);

/// The largest grid of the proportions of `dims` (each axis scaled by the same factor, at least 1) with at most
/// `maxSamples` samples; `dims` itself when it fits. Returns true when it clamped.
bool clampGrid(const int64_t dims[3], int64_t maxSamples, int64_t out[3]);

struct SourceInfo;
/// A decode may sample the finest hash-grid level up to this many times per axis (the MLP bends the field inside a
/// finest cell, so twice its vertices still shows something); finer grids only interpolate, at a cost that grows with
/// the cube of the resolution.
constexpr int kDecodeOversampling = 2;

/// Samples per axis that a network of this encoding resolves: the vertices of its finest hash-grid level (a finer
/// decode interpolates between them). Throws nv::Error for an invalid encoding.
int resolvedSamplesPerAxis(const EncodingConfig& encoding);

/// The decode grid a renderer on `device` uses for `asked` (DecodeResolution; 0 on an axis: the source's dims,
/// negative: as 0): at most kDecodeOversampling x `resolved` samples per axis (resolvedSamplesPerAxis; never below the
/// source's own dims; 0: no such cap), kMaxDecodeResolution per axis, kMaxDecodeGridSamples and the memory the machine has (host
/// for the CPU renderer, kDeviceMemoryShare of the GPU's free memory for the CUDA one), its proportions kept. `used`
/// is all 0 when the source's dims are used unclamped. Returns why it clamped ("" when it did not).
std::string fitDecodeGrid(
  const SourceInfo& source, Device device, const int asked[3], int used[3], int resolved = 0);

/// Samples the renderers decode at most (the CPU renderer's limit, kept for both devices).
constexpr int64_t kMaxDecodeGridSamples = int64_t(1) << 31;
/// Samples per axis of a decode grid the engine accepts (RenderRequest::decodeResolution).
constexpr int kMaxDecodeResolution = 8192;

} // namespace nv
