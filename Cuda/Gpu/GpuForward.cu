// NeuralVolume engine: host side of the register-resident forward kernel (GpuForward.cuh): kernel choice and
// launch for inference and decoding.
#include "GpuForward.cuh"
#include "GpuInternal.cuh"

#include <algorithm>
#include <cstdlib>

namespace nv
{
namespace gpu
{

namespace
{
using FwdFn = void (*)(FwdArgs);

/// Mode (NV_GPU_FWD_MODE, for benchmarks): 0 fused encode+MLP for all inputs; 1 (default) two passes (level-major
/// encode, then MLP) for point arrays, fused for grid decoding; 2 two passes for both.
int forwardMode()
{
  static const int v = [] {
    const char* e = std::getenv("NV_GPU_FWD_MODE");
    const int x = e ? std::atoi(e) : -1;
    return x >= 0 && x <= 2 ? x : 1;
  }();
  return v;
}

template <int W, int F>
struct FwdPick
{
  static FwdFn fn(bool pre) { return pre ? forwardKernel<W, F, 8, 2, true> : forwardKernel<W, F, 8, 2, false>; }
};

FwdFn pickForward(int W, int F, bool pre)
{
#define NV_CASE(w, f)                                                                              \
  if (W == w && F == f)                                                                            \
    return FwdPick<w, f>::fn(pre);
  NV_CASE(16, 1) NV_CASE(16, 2) NV_CASE(16, 4) NV_CASE(16, 8)
  NV_CASE(32, 1) NV_CASE(32, 2) NV_CASE(32, 4) NV_CASE(32, 8)
  NV_CASE(64, 1) NV_CASE(64, 2) NV_CASE(64, 4) NV_CASE(64, 8)
#undef NV_CASE
  return nullptr;
}

void launchEncodeLevels(int F, const FwdArgs& a, __half* enc, cudaStream_t stream)
{
  const dim3 grid(static_cast<unsigned>((a.n + 255) / 256), static_cast<unsigned>(a.grid.levels));
  switch (F)
  {
    case 1: encodeLevelsKernel<1><<<grid, 256, 0, stream>>>(a, enc); break;
    case 2: encodeLevelsKernel<2><<<grid, 256, 0, stream>>>(a, enc); break;
    case 4: encodeLevelsKernel<4><<<grid, 256, 0, stream>>>(a, enc); break;
    default: encodeLevelsKernel<8><<<grid, 256, 0, stream>>>(a, enc); break;
  }
  NV_CUDA_LAUNCH();
}

} // namespace

/// Register-resident fast path; false when the shape is not covered (then the WMMA kernel of GpuInference.cu runs).
bool launchForward(const DeviceModel& dm, const float* xyz, int64_t nx, int64_t ny, int64_t nz, int64_t z0,
  int64_t first, int64_t n, float* out, cudaStream_t stream)
{
  const int mode = forwardMode();
  const bool pre = mode == 2 || (mode == 1 && xyz != nullptr);
  const FwdFn fn = pickForward(dm.shape.W, dm.grid.features, pre);
  if (!fn || dm.shape.H > kMaxHidden)
    return false;
  constexpr int warps = 8;
  FwdArgs a{};
  a.grid = dm.grid;
  a.shape = dm.shape;
  const int bytes = fwdLayout(dm.shape, warps, a);
  if (bytes > deviceInfo().maxSmemOptin)
    return false;
  const void* fp = reinterpret_cast<const void*>(fn);
  NV_CUDA(cudaFuncSetAttribute(fp, cudaFuncAttributeMaxDynamicSharedMemorySize, bytes));
  int perSm = 0;
  NV_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&perSm, fp, warps * 32, bytes));
  if (perSm < 1)
    return false;
  a.table16 = dm.table16.get();
  a.w16 = dm.w16.get();
  a.wout = dm.wout.get();
  a.nx = nx;
  a.ny = ny;
  a.nz = nz;
  a.z0 = z0;
  a.enc = nullptr;
  a.random = 0;
  a.seed = a.step = 0;
  // Two-pass mode works in chunks whose encodings (D halves per sample) fit a 128 MiB scratch buffer.
  const int64_t D = int64_t(dm.grid.levels) * dm.grid.features;
  const int64_t chunk = pre ? std::min<int64_t>(n, (int64_t(128) << 20) / (2 * D)) : n;
  if (pre && dm.encScratch.size() < size_t(chunk * D))
    dm.encScratch.allocate(size_t(chunk * D), "encoding scratch");
  for (int64_t b = 0; b < n; b += chunk)
  {
    const int64_t m = std::min(chunk, n - b);
    a.xyz = xyz ? xyz + 3 * b : nullptr;
    a.first = first + b;
    a.n = m;
    a.out = out + b;
    a.tiles = (m + 15) / 16;
    if (pre)
    {
      a.enc = dm.encScratch.get();
      launchEncodeLevels(dm.grid.features, a, dm.encScratch.get(), stream);
    }
    const int64_t blocks = std::min<int64_t>((a.tiles + warps - 1) / warps, int64_t(perSm) * deviceInfo().sms);
    fn<<<static_cast<int>(blocks), warps * 32, bytes, stream>>>(a);
    NV_CUDA_LAUNCH();
  }
  return true;
}

} // namespace gpu
} // namespace nv
