// NeuralVolume engine: host side of the register-resident forward kernel (GpuForward.cuh): kernel choice and
// launch for inference and decoding.
#include "GpuBinning.cuh"
#include "GpuForward.cuh"
#include "GpuInternal.cuh"

#include <cub/device/device_scan.cuh>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace nv
{
namespace gpu
{

namespace
{
using FwdFn = void (*)(FwdArgs);

/// Fused (grid decoding): 2 blocks per SM, L1 left for the coarse levels' gathers. Two-pass MLP pass (point
/// arrays): 3 blocks per SM (80 registers): measured 1.62 -> 1.69 G samples/s on binned random points. Widths 16 and
/// 32 always have their weights in shared memory (at most 34 KiB); widths 64 (up to 98 KiB: 8 hidden layers after
/// 256 inputs, more than a Turing or an sm_86 block holds) and 128 read them through L1 when they do not fit.
template <int W, int F, typename Weights, int Warps = 8>
struct FwdPick
{
  // Width 128 holds 64 accumulators and 32 A registers per lane: one block per SM (no spills).
  static constexpr int kPre = W <= 64 ? 3 : 1, kFused = W <= 64 ? 2 : 1;
  static FwdFn fn(bool pre)
  {
    return pre ? forwardKernel<W, F, Warps, kPre, true, Weights> : forwardKernel<W, F, Warps, kFused, false, Weights>;
  }
};

/// The forward kernel for a shape, 8 warps per block; 4 warps exist for width 128 with its weights through L1 (its
/// 8-warp staging of 256 inputs, 66 KiB, exceeds a Turing block's 64 KiB).
FwdFn pickForward(int W, int F, bool pre, bool shared, int warps)
{
  if (warps == 4)
  {
#define NV_CASE(f)                                                                                 \
  if (W == 128 && F == f && !shared)                                                               \
    return FwdPick<128, f, WeightsInGlobal, 4>::fn(pre);
    NV_CASE(1) NV_CASE(2) NV_CASE(4) NV_CASE(8)
#undef NV_CASE
    return nullptr;
  }
  if (warps != 8)
    return nullptr;
#define NV_CASE(w, f)                                                                              \
  if (W == w && F == f)                                                                            \
    return FwdPick<w, f, WeightsInShared>::fn(pre);
  if (shared)
  {
    NV_CASE(16, 1) NV_CASE(16, 2) NV_CASE(16, 4) NV_CASE(16, 8)
    NV_CASE(32, 1) NV_CASE(32, 2) NV_CASE(32, 4) NV_CASE(32, 8)
  }
#undef NV_CASE
#define NV_CASE(w, f)                                                                              \
  if (W == w && F == f)                                                                            \
    return shared ? FwdPick<w, f, WeightsInShared>::fn(pre) : FwdPick<w, f, WeightsInGlobal>::fn(pre);
  NV_CASE(64, 1) NV_CASE(64, 2) NV_CASE(64, 4) NV_CASE(64, 8)
  NV_CASE(128, 1) NV_CASE(128, 2) NV_CASE(128, 4) NV_CASE(128, 8)
#undef NV_CASE
  return nullptr; // widths 16 and 32 without shared weights: not instantiated (their weights always fit)
}

__global__ void zeroCountsKernel(uint32_t* __restrict__ counts, int64_t n)
{
  for (int64_t i = blockIdx.x * int64_t(blockDim.x) + threadIdx.x; i < n; i += int64_t(gridDim.x) * blockDim.x)
    counts[i] = 0;
}

/// Bins for m points (2^(3 bits) bins) and the scan's scratch, allocated if smaller; returns the scratch's size.
size_t reserveBins(const DeviceModel& dm, int64_t m, int bits)
{
  PointBins& b = dm.bins;
  const size_t nb = size_t(1) << (3 * bits);
  if (b.binned.size() < size_t(m))
  {
    b.binned.allocate(size_t(m), "binned points");
    b.rank.allocate(size_t(m), "bin ranks");
  }
  if (b.counts.size() < nb)
  {
    b.counts.allocate(nb, "bin counts");
    b.offsets.allocate(nb, "bin offsets");
  }
  size_t temp = 0;
  NV_CUDA(cub::DeviceScan::ExclusiveSum(nullptr, temp, b.counts.get(), b.offsets.get(), static_cast<int>(nb), 0));
  if (b.scanTemp.size() < temp)
    b.scanTemp.allocate(temp, "scan scratch");
  return temp;
}

/// Counting sort of m points by Morton bin (2^(3 bits) bins) into dm.bins.binned (liveCount: a device-side count
/// of points from liveBase on, m the capacity; see FwdArgs::liveCount).
void binPoints(const DeviceModel& dm, const float* xyz, int64_t m, int bits, cudaStream_t stream,
  const uint32_t* liveCount, int64_t liveBase)
{
  PointBins& b = dm.bins;
  const size_t nb = size_t(1) << (3 * bits);
  size_t temp = reserveBins(dm, m, bits);
  if (liveCount)
  {
    // (A kernel, not a memset node: the launch may be captured into a CUDA graph's loop body.)
    zeroCountsKernel<<<gridFor(int64_t(nb)), 256, 0, stream>>>(b.counts.get(), int64_t(nb));
    NV_CUDA_LAUNCH();
  }
  else
    NV_CUDA(cudaMemsetAsync(b.counts.get(), 0, nb * sizeof(uint32_t), stream));
  binCountKernel<<<gridFor(m), 256, 0, stream>>>(xyz, m, bits, b.counts.get(), b.rank.get(), liveCount, liveBase);
  NV_CUDA_LAUNCH();
  NV_CUDA(cub::DeviceScan::ExclusiveSum(b.scanTemp.get(), temp, b.counts.get(), b.offsets.get(), static_cast<int>(nb),
    stream));
  binScatterKernel<<<gridFor(m), 256, 0, stream>>>(xyz, m, bits, b.rank.get(), b.offsets.get(), b.binned.get(),
    liveCount, liveBase);
  NV_CUDA_LAUNCH();
}

template <int Lpt>
void launchEncodeLevelsL(int F, const FwdArgs& a, __half* enc, cudaStream_t stream)
{
  // A device-side count: a grid of what the GPU holds at once, striding over the samples (most of the capacity is
  // usually empty; a grid per sample would launch its blocks anyway).
  int64_t blocks = (a.sampleCount + 255) / 256;
  if (a.liveCount)
    blocks = std::min<int64_t>(blocks, int64_t(deviceInfo().sms) * 8);
  const dim3 grid(static_cast<unsigned>(blocks), static_cast<unsigned>((a.grid.levels + Lpt - 1) / Lpt));
  switch (F)
  {
    case 1: encodeLevelsKernel<1, __half, Lpt><<<grid, 256, 0, stream>>>(a, enc); break;
    case 2: encodeLevelsKernel<2, __half, Lpt><<<grid, 256, 0, stream>>>(a, enc); break;
    case 4: encodeLevelsKernel<4, __half, Lpt><<<grid, 256, 0, stream>>>(a, enc); break;
    default: encodeLevelsKernel<8, __half, Lpt><<<grid, 256, 0, stream>>>(a, enc); break;
  }
  NV_CUDA_LAUNCH();
}

/// Levels per thread (KernelOptions::encodeLevelsPerThread 1 / 2 / 4, default 4): 4 reads each point once for four
/// levels (measured on binned random points, 2^21: 1.68 / 1.71 / 1.73 G samples/s).
void launchEncodeLevels(int lpt, int F, const FwdArgs& a, __half* enc, cudaStream_t stream)
{
  if (lpt == 4)
    launchEncodeLevelsL<4>(F, a, enc, stream);
  else if (lpt == 2)
    launchEncodeLevelsL<2>(F, a, enc, stream);
  else
    launchEncodeLevelsL<1>(F, a, enc, stream);
}

} // namespace

/// Bits per axis of the Morton bins for m points (0: no binning): about 32 points per bin (1M random points:
/// 2^5 bins per axis measured best, 2^6 within 1%); from 2^18 points (2^16 random points: 0.079 ms unbinned,
/// 0.087 binned; 2^18: 0.202 / 0.196). KernelOptions::binBitsPerAxis >= 0 forces a value.
int inferenceBinBits(int64_t m, int forced)
{
  if (forced >= 0)
    return std::min(forced, 8);
  if (m < (int64_t(1) << 18))
    return 0;
  const int b = static_cast<int>(std::floor(std::log2(static_cast<double>(m) / 32.0) / 3.0));
  return std::max(3, std::min(7, b));
}

/// Kernel, shared memory and occupancy of the forward kernel for a model (once per model and mode).
const ForwardPlan& forwardPlan(const DeviceModel& dm, bool pre)
{
  ForwardPlan& p = dm.fwdPlan[pre ? 1 : 0];
  if (p.fn)
    return p;
  NV_CHECK(dm.shape.hiddenLayers <= kMaxHidden, "too many hidden layers for the GPU");
  const int limit = sharedMemoryLimit(dm.options);
  for (bool shared : { true, false })
    for (int warps : { 8, 4 })
    {
      FwdArgs a{};
      const int bytes = fwdLayout(dm.shape, warps, shared, a);
      const FwdFn fn = pickForward(dm.shape.width, dm.grid.features, pre, shared, warps);
      if (!fn || bytes > limit)
        continue;
      const void* fp = reinterpret_cast<const void*>(fn);
      NV_CUDA(cudaFuncSetAttribute(fp, cudaFuncAttributeMaxDynamicSharedMemorySize, bytes));
      int perSm = 0;
      NV_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&perSm, fp, warps * 32, bytes));
      if (perSm < 1)
        continue;
      p.fn = fp;
      p.shared = shared;
      p.bytes = bytes;
      p.blocksPerSm = perSm;
      p.warps = warps;
      return p;
    }
  NV_THROW("this network shape (width " + std::to_string(dm.shape.width) + ", " + std::to_string(dm.grid.features) +
    " features per level) cannot run on the GPU within " + std::to_string(limit / 1024) +
    " KiB of shared memory per block");
}

namespace
{
/// Two-pass mode: samples per chunk (their encodings, D halves each, fit the scratch).
int64_t forwardChunk(const DeviceModel& dm, bool pre, int64_t n)
{
  const int64_t D = int64_t(dm.grid.levels) * dm.grid.features;
  const int64_t scratchBytes = int64_t(std::max(16, dm.options.encodeScratchMiB)) << 20;
  return pre ? std::max<int64_t>(1, std::min<int64_t>(n, scratchBytes / (2 * D))) : n;
}

bool forwardPre(const DeviceModel& dm, bool points)
{
  const int mode = dm.options.forwardMode >= 0 && dm.options.forwardMode <= 2 ? dm.options.forwardMode : 1;
  return mode == 2 || (mode == 1 && points);
}
} // namespace

int64_t inferenceChunk(const DeviceModel& dm)
{
  return forwardChunk(dm, forwardPre(dm, true), std::numeric_limits<int64_t>::max());
}

void reserveInference(const DeviceModel& dm, int64_t capacity)
{
  const bool pre = forwardPre(dm, true);
  forwardPlan(dm, pre);
  if (!pre || capacity <= 0)
    return;
  const int64_t chunk = forwardChunk(dm, pre, capacity);
  const int64_t D = int64_t(dm.grid.levels) * dm.grid.features;
  if (dm.encScratch.size() < size_t(chunk * D))
    dm.encScratch.allocate(size_t(chunk * D), "encoding scratch");
  const int bits = inferenceBinBits(chunk, dm.options.binBitsPerAxis);
  if (bits > 0)
    reserveBins(dm, chunk, bits);
}

/// Inference and decoding through the forward kernel.
void launchForward(const DeviceModel& dm, const float* xyz, int64_t nx, int64_t ny, int64_t nz, int64_t z0,
  int64_t first, int64_t n, float* out, cudaStream_t stream, const uint32_t* liveCount)
{
  NV_CHECK(!liveCount || xyz, "a device-side sample count needs a point array");
  const KernelOptions& o = dm.options;
  const bool pre = forwardPre(dm, xyz != nullptr);
  const ForwardPlan& plan = forwardPlan(dm, pre);
  const FwdFn fn = reinterpret_cast<FwdFn>(plan.fn);
  const int warps = plan.warps;
  const int bytes = plan.bytes;
  const int perSm = plan.blocksPerSm;
  FwdArgs a{};
  a.grid = dm.grid;
  a.shape = dm.shape;
  fwdLayout(dm.shape, warps, plan.shared, a);
  a.table16 = dm.table16.get();
  a.w16 = dm.w16.get();
  a.wout = dm.wout.get();
  a.nx = nx;
  a.ny = ny;
  a.nz = nz;
  a.z0 = z0; // enc, binned, random, seed, step stay zero (a{})
  // Two-pass mode works in chunks whose encodings (D halves per sample) fit the scratch buffer (encodeScratchMiB).
  const int64_t D = int64_t(dm.grid.levels) * dm.grid.features;
  const int64_t chunk = forwardChunk(dm, pre, n);
  a.liveCount = liveCount;
  if (pre && dm.encScratch.size() < size_t(chunk * D))
    dm.encScratch.allocate(size_t(chunk * D), "encoding scratch");
  for (int64_t b = 0; b < n; b += chunk)
  {
    const int64_t m = std::min(chunk, n - b);
    a.xyz = xyz ? xyz + 3 * b : nullptr;
    a.first = first + b;
    a.sampleCount = m;
    a.liveBase = b;
    a.out = out + b;
    if (pre)
    {
      const int bits = a.xyz ? inferenceBinBits(m, o.binBitsPerAxis) : 0;
      if (bits > 0)
      {
        binPoints(dm, a.xyz, m, bits, stream, liveCount, b);
        a.binned = dm.bins.binned.get();
      }
      a.enc = dm.encScratch.get();
      launchEncodeLevels(o.encodeLevelsPerThread, dm.grid.features, a, dm.encScratch.get(), stream);
    }
    const int64_t tiles = (m + 15) / 16;
    const int64_t blocks = std::min<int64_t>((tiles + warps - 1) / warps, int64_t(perSm) * deviceInfo().sms);
    fn<<<static_cast<int>(blocks), warps * 32, bytes, stream>>>(a);
    NV_CUDA_LAUNCH();
  }
}

} // namespace gpu
} // namespace nv
