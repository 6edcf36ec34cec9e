// NeuralVolume engine: host-side helpers shared by the CUDA translation units.
#pragma once

#include "Core/Model.h"
#include "Core/NetworkSession.h"
#include "GpuCommon.cuh"
#include "GpuNetwork.cuh"

#include <string>

namespace nv
{
namespace gpu
{

struct DeviceInfo
{
  int device = 0;
  int sms = 0;
  int maxSmemOptin = 0;
  size_t totalMem = 0;
  std::string name;
  int major = 0, minor = 0;
};
/// Properties of the calling thread's current device (queried once per device).
const DeviceInfo& deviceInfo();
/// The calling thread's current CUDA device.
int currentDevice();
/// Makes `ordinal` the calling thread's current device (cudaSetDevice when it is another one; the runtime keeps it
/// for the thread). Every entry point of a session and of its trainers calls it with the session's device, so a
/// session made for device 1 works from any thread (a new thread starts on device 0).
void useDevice(int ordinal);
/// Blocks for a grid-stride loop over n items (at most 32 blocks per SM).
int gridFor(int64_t n, int threads = 256);

/// Scratch of the spatial binning of point arrays (GpuBinning.cuh), grown on demand.
struct PointBins
{
  DeviceBuffer<float4> binned;    ///< the points in bin order, original index in w
  DeviceBuffer<uint32_t> rank;    ///< per point: rank within its bin
  DeviceBuffer<uint32_t> counts;  ///< per bin
  DeviceBuffer<uint32_t> offsets; ///< exclusive scan of counts
  DeviceBuffer<unsigned char> scanTemp;
};

/// The forward kernel chosen for a model (GpuForward.cu), found once.
struct ForwardPlan
{
  const void* fn = nullptr;
  bool shared = true; ///< weights in shared memory
  int bytes = 0;      ///< dynamic shared memory
  int blocksPerSm = 0;
  int warps = 8;      ///< per block (4: width 128 whose 8-warp staging exceeds the GPU's shared memory, e.g. Turing)
};

/// The parameters in the form the kernels read: fp16 table, padded fp16 MLP, fp32 output row.
struct DeviceModel
{
  GridLayout grid{};
  MlpShape shape{};
  KernelOptions options; ///< kernel variants of every launch on this model
  DeviceBuffer<__half> table16;
  DeviceBuffer<__half> w16;
  DeviceBuffer<float> wout;
  mutable DeviceBuffer<__half> encScratch; ///< two-pass inference: encodings of a chunk (GpuForward.cu)
  mutable PointBins bins;                  ///< two-pass inference on point arrays (GpuForward.cu)
  mutable ForwardPlan fwdPlan[2];          ///< fused / two-pass forward kernel (GpuForward.cu)
  size_t bytes() const { return table16.bytes() + w16.bytes() + wout.bytes(); }
};

/// Allocate the fp16 copies for a configuration.
void allocateDeviceModel(const Model& model, DeviceModel& dm);
/// Fill dm's fp16 copies from the full fp32 parameter vector on the device (Model::params layout).
void packParams(const float* dParams, DeviceModel& dm, cudaStream_t stream);
/// Upload a host model.
void uploadModel(const Model& model, DeviceModel& dm, cudaStream_t stream);

/// Bits per axis of the Morton bins that inference on m random points uses (0: no binning); forced >= 0
/// (KernelOptions::binBitsPerAxis) overrides.
int inferenceBinBits(int64_t m, int forced);

/// Dynamic shared memory per block the kernels may use: the device's opt-in maximum, or options.sharedMemoryLimit
/// when smaller.
int sharedMemoryLimit(const KernelOptions& options);

/// Shared-memory plan for kernel fn within `limit` bytes: weights in shared memory and the largest tile that fit
/// (else weights through L1); blocksPerSm receives its occupancy.
SmemPlan choosePlan(const MlpShape& s, bool training, const void* fn, int limit, int* blocksPerSm);

/// Kernel, shared memory and occupancy of the forward kernel for a model (pre: two-pass, encodings precomputed),
/// chosen once per model within sharedMemoryLimit(dm.options).
const ForwardPlan& forwardPlan(const DeviceModel& dm, bool pre);

/// The forward kernel (GpuForward.cu) on points or grid slices; see launchInference. liveCount (device memory, with
/// xyz only): the points are [0, *liveCount) clamped to n, read when the kernels run; n is then the capacity, and
/// the launch allocates nothing after reserveInference(dm, n) (a CUDA graph may capture it).
void launchForward(const DeviceModel& dm, const float* xyz, int64_t nx, int64_t ny, int64_t nz, int64_t z0,
  int64_t first, int64_t n, float* out, cudaStream_t stream, const uint32_t* liveCount = nullptr);

/// Points of one launch chunk of xyz inference (two-pass mode: the encodings scratch's worth; else unbounded).
int64_t inferenceChunk(const DeviceModel& dm);

/// Everything launchForward allocates for up to `capacity` points (xyz inference), allocated now, and the kernel
/// plan chosen.
void reserveInference(const DeviceModel& dm, int64_t capacity);

/// Run the inference kernel: xyz (device, n x 3) or, when xyz is null, the grid points
/// [first, first + n) of slices starting at z0 of an nx*ny*nz grid. out: device, n floats.
void launchInference(const DeviceModel& dm, const float* xyz, int64_t nx, int64_t ny, int64_t nz, int64_t z0,
  int64_t first, int64_t n, float* out, cudaStream_t stream);

} // namespace gpu
} // namespace nv
