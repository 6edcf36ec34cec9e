// NeuralVolume engine: the In-Shader render path on the GPU. Persistent warps: each lane owns a ray (a pixel's
// path); every iteration each live lane emits the queries of its next step, the warp evaluates all of them together
// with the one forward pass (GpuWarpForward.cuh; tiles of 16 on the tensor cores, fp16 accumulation by default for
// fewer registers next to the ray state), and each lane consumes its values. A lane whose ray ends takes the next
// pixel from a global counter, so lanes keep participating until the image is done.
#include "GpuForward.cuh"
#include "GpuRenderInShader.cuh"
#include "GpuRenderCommon.cuh"

#include <string>

namespace nv
{
namespace gpu
{
namespace
{

/// The lane's n queries packed into the warp's staging qs at its exclusive prefix sum `off` of the counts; returns
/// the warp's total.
__device__ __forceinline__ int packWarpQueries(const ray::V3 (&q)[ray::kMaxQueriesPerStep], int n, int lane, float* qs,
  int& off)
{
  int incl = n;
  for (int o = 1; o < 32; o <<= 1)
  {
    const int y = __shfl_up_sync(0xffffffffu, incl, o);
    incl += lane >= o ? y : 0;
  }
  off = incl - n;
  const int total = __shfl_sync(0xffffffffu, incl, 31);
  for (int k = 0; k < n; ++k)
  {
    qs[3 * (off + k)] = q[k].x;
    qs[3 * (off + k) + 1] = q[k].y;
    qs[3 * (off + k) + 2] = q[k].z;
  }
  return total;
}

/// The network at the warp's `total` staged queries, 16 at a time (the one forward pass), values into vs.
template <int W, int F, bool HalfAcc, typename Weights>
__device__ __forceinline__ void evaluateWarpQueries(const InShaderArgs& a, const WarpNet& net,
  const EncodeFrom<__half>& src, const float* qs, float* vs, __half* enc, int total, int lane)
{
  for (int t0 = 0; t0 < total; t0 += 16)
  {
    const int idx = t0 + (lane & 15);
    float x[3] = { 0.0f, 0.0f, 0.0f };
    if (idx < total)
    {
      x[0] = qs[3 * idx];
      x[1] = qs[3 * idx + 1];
      x[2] = qs[3 * idx + 2];
    }
    WarpOut<W> out;
    warpForward<W, F, HalfAcc, Weights>(a.grid, a.shape, net, src, x, enc, a.ldE, lane, NoStage{}, out);
    if ((lane & 3) == 0)
    {
      const int g = lane >> 2;
      if (t0 + g < total)
        vs[t0 + g] = out.lo;
      if (t0 + g + 8 < total)
        vs[t0 + g + 8] = out.hi;
    }
    __syncwarp(); // values written, and this tile's reads of enc done before the next tile encodes
  }
}

template <int W, int F, bool HalfAcc, typename Weights>
__global__ void __launch_bounds__(256, 1) inShaderKernel(const __grid_constant__ InShaderArgs a)
{
  extern __shared__ __align__(128) unsigned char smem[];
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  const WarpNet net = stageNet<Weights>(a.shape, a.w16, a.wout, reinterpret_cast<__half*>(smem), a.wOff,
    reinterpret_cast<float*>(smem + a.woutOff));
  __half* enc = reinterpret_cast<__half*>(smem + a.encOff) + warp * 16 * a.ldE;
  float* qs = reinterpret_cast<float*>(smem + a.qOff) + warp * 32 * ray::kMaxQueriesPerStep * 3;
  float* vs = reinterpret_cast<float*>(smem + a.vOff) + warp * 32 * ray::kMaxQueriesPerStep;
  for (int i = lane; i < 16 * a.ldE; i += 32)
    enc[i] = __float2half(0.0f); // padding columns D..Dp-1 stay zero
  __syncthreads();

  const ray::Params& P = a.rayParams;
  const EncodeFrom<__half> src{ a.table16 };
  const unsigned below = (1u << lane) - 1u;
  ray::Ray r;
  bool live = false, exhausted = false;
  unsigned long long evaluated = 0, plain = 0;
  for (;;)
  {
    // Lanes without a ray take the next ones (one atomic per warp). This step and the consume step below stay inline:
    // as helpers (the ray, live and the counters by reference) they changed the kernels' SASS.
    const bool need = !live && !exhausted;
    const unsigned m = __ballot_sync(0xffffffffu, need);
    if (m)
    {
      const int leader = __ffs(m) - 1;
      unsigned base = 0;
      if (lane == leader)
        base = atomicAdd(&a.counters->nextRay, static_cast<unsigned>(__popc(m)));
      base = __shfl_sync(0xffffffffu, base, leader);
      if (need)
      {
        const unsigned id = base + static_cast<unsigned>(__popc(m & below));
        if (id < a.total)
        {
          ray::initRay(P, static_cast<int>(id % P.width), static_cast<int>(id / P.width), r, a.sample);
          if (r.phase == ray::Done)
            writePixel(r, a.image, a.accum);
          else
            live = true;
        }
        else
        {
          exhausted = true;
        }
      }
    }
    if (__all_sync(0xffffffffu, !live && exhausted))
      break;
    // The queries of every live lane, packed in the warp's staging, evaluated together.
    ray::V3 q[ray::kMaxQueriesPerStep];
    const int n = live ? ray::emit(P, r, 1, q) : 0;
    int off;
    const int total = packWarpQueries(q, n, lane, qs, off);
    __syncwarp();
    evaluateWarpQueries<W, F, HalfAcc, Weights>(a, net, src, qs, vs, enc, total, lane);
    if (live)
    {
      float v[ray::kMaxQueriesPerStep];
      for (int k = 0; k < n; ++k)
        v[k] = vs[off + k];
      ray::maskOutsideDomain(P, q, v, n);
      ray::consume(P, r, 1, v, n);
      evaluated += n;
      if (r.phase == ray::Done)
      {
        plain += r.plain;
        writePixel(r, a.image, a.accum);
        live = false;
      }
    }
    __syncwarp();
  }
  warpAdd(&a.counters->evaluated, evaluated);
  warpAdd(&a.counters->plain, plain);
}

using InShaderFn = void (*)(InShaderArgs);

template <int W, int F, typename Weights>
InShaderFn pickAcc(bool half)
{
  return half ? inShaderKernel<W, F, true, Weights> : inShaderKernel<W, F, false, Weights>;
}

InShaderFn pickInShader(int W, int F, bool half, bool shared)
{
#define NV_CASE(w, f)                                                                              \
  if (W == w && F == f)                                                                            \
    return pickAcc<w, f, WeightsInShared>(half);
  NV_CASE(16, 1) NV_CASE(16, 2) NV_CASE(16, 4) NV_CASE(16, 8)
  NV_CASE(32, 1) NV_CASE(32, 2) NV_CASE(32, 4) NV_CASE(32, 8)
  NV_CASE(64, 1) NV_CASE(64, 2) NV_CASE(64, 4) NV_CASE(64, 8)
#undef NV_CASE
  // Width 128: weights through L1 (they rarely fit next to the per-warp staging).
#define NV_CASE(f)                                                                                 \
  if (W == 128 && F == f)                                                                          \
    return pickAcc<128, f, WeightsInGlobal>(half);
  NV_CASE(1) NV_CASE(2) NV_CASE(4) NV_CASE(8)
#undef NV_CASE
  (void)shared;
  return nullptr;
}

} // namespace

namespace
{
/// Shared-memory layout of the In-Shader kernel for `warps` warps per block: weights (when shared), output row, per
/// warp: encodings (16 rows), queries and values. Returns the bytes.
int inShaderLayout(const MlpShape& s, int warps, bool shared, InShaderArgs& a)
{
  FwdArgs f{};
  size_t o = static_cast<size_t>(fwdLayout(s, warps, shared, f)) - size_t(warps) * 16 * f.ldE * 2;
  for (int l = 0; l < kMaxHidden; ++l)
    a.wOff[l] = f.wOff[l];
  a.woutOff = f.woutOff;
  a.encOff = f.encOff;
  a.ldE = f.ldE;
  o = roundUp128(o + size_t(warps) * 16 * a.ldE * 2);
  a.qOff = static_cast<int>(o);
  o = roundUp128(o + size_t(warps) * 32 * ray::kMaxQueriesPerStep * 3 * sizeof(float));
  a.vOff = static_cast<int>(o);
  o += size_t(warps) * 32 * ray::kMaxQueriesPerStep * sizeof(float);
  return static_cast<int>(o);
}
} // namespace

void launchInShader(const DeviceModel& dm, InShaderArgs& a, cudaStream_t stream, int* blocksUsed)
{
  const bool shared = dm.shape.width <= 64;
  const InShaderFn fn = pickInShader(dm.shape.width, dm.grid.features, dm.options.inShaderHalfAccumulate, shared);
  NV_CHECK(fn != nullptr, "this network shape cannot be rendered In-Shader on the GPU");
  a.grid = dm.grid;
  a.shape = dm.shape;
  a.table16 = dm.table16.get();
  a.w16 = dm.w16.get();
  a.wout = dm.wout.get();
  // The most warps per block whose staging fits the GPU's shared memory (8 on Hopper and Ampere; fewer on a GPU
  // with less shared memory per block, e.g. a large network on Turing's 64 KiB).
  const int limit = sharedMemoryLimit(dm.options);
  const void* fp = reinterpret_cast<const void*>(fn);
  int warps = 0, bytes = 0, perSm = 0;
  for (int w : { 8, 4, 2, 1 })
  {
    const int b = inShaderLayout(dm.shape, w, shared, a);
    if (b > limit)
      continue;
    NV_CUDA(cudaFuncSetAttribute(fp, cudaFuncAttributeMaxDynamicSharedMemorySize, b));
    NV_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&perSm, fp, w * 32, b));
    if (perSm >= 1)
    {
      warps = w;
      bytes = b;
      break;
    }
  }
  NV_CHECK(warps > 0, "the network is too large for In-Shader rendering on this GPU (" + std::to_string(limit / 1024) +
    " KiB of shared memory per block); use Sample Streaming");
  const int64_t needed = (int64_t(a.total) + warps * 32 - 1) / (warps * 32);
  const int blocks = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(needed, int64_t(perSm) * deviceInfo().sms)));
  fn<<<blocks, warps * 32, bytes, stream>>>(a);
  NV_CUDA_LAUNCH();
  if (blocksUsed)
    *blocksUsed = blocks;
}

} // namespace gpu
} // namespace nv
