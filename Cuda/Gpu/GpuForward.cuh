// NeuralVolume engine: the inference and decoding kernel: persistent warps over 16-sample tiles, each calling the
// forward pass (GpuWarpForward.cuh). Pre = true: the encodings come from the level-major pass (point arrays);
// else each warp encodes its samples (grid decoding). Weights in shared memory when they fit (else read through
// L1: wide networks).
#pragma once

#include "GpuWarpForward.cuh"

namespace nv
{
namespace gpu
{

/// Shared-memory layout of the forward kernel for blocks of `warps` warps; returns its size in bytes. Weights
/// only when `weightsInShared`.
inline int fwdLayout(const MlpShape& s, int warps, bool weightsInShared, FwdArgs& a)
{
  size_t wh = 0;
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    a.wOff[l] = static_cast<int>(wh);
    wh += static_cast<size_t>(s.width) * (s.inDim(l) + 8);
  }
  size_t o = weightsInShared ? roundUp128(wh * 2) : 0;
  a.woutOff = static_cast<int>(o);
  o += roundUp128(s.width * 4);
  a.encOff = static_cast<int>(o);
  a.ldE = s.paddedInputs + 8;
  o += static_cast<size_t>(warps) * 16 * a.ldE * 2;
  return static_cast<int>(o);
}

/// Stage the padded fp16 weights (ld K + 8) into shared memory at sw (layer l at wOff[l]; when Weights is
/// WeightsInShared) and the fp32 output row at swout; returns the net as the forward pass reads it. Block-wide; the
/// caller synchronises. `wOff` and `s` must live in kernel-parameter memory.
template <typename Weights>
__device__ __forceinline__ WarpNet stageNet(const MlpShape& s, const __half* __restrict__ w16,
  const float* __restrict__ wout, __half* sw, const int* wOff, float* swout)
{
  WarpNet net;
  if constexpr (std::is_same<Weights, WeightsInShared>::value)
  {
    for (int l = 0; l < s.hiddenLayers; ++l)
    {
      const int K = s.inDim(l), kv = K / 8;
      const uint4* src = reinterpret_cast<const uint4*>(w16 + s.off[l]);
      __half* dst = sw + wOff[l];
      for (int i = threadIdx.x; i < s.width * kv; i += blockDim.x)
        *reinterpret_cast<uint4*>(dst + (i / kv) * (K + 8) + (i % kv) * 8) = src[i];
    }
    net = WarpNet{ sw, wOff, s.paddedInputs + 8, s.width + 8, swout };
  }
  else
  {
    net = WarpNet{ w16, s.off, s.paddedInputs, s.width, swout };
  }
  for (int i = threadIdx.x; i < s.width; i += blockDim.x)
    swout[i] = wout[i];
  return net;
}

template <int W, int F, int Warps, int MinBlocks, bool Pre, typename Weights>
__global__ void __launch_bounds__(Warps * 32, MinBlocks) forwardKernel(const __grid_constant__ FwdArgs a)
{
  extern __shared__ __align__(128) unsigned char smem[];
  const int64_t n = liveSamples(a); // sampleCount, or a device-side count (the same for every thread)
  if (int64_t(blockIdx.x) * Warps * 16 >= n)
    return; // no tile for this block (a grid sized for a device-side count's capacity): skip staging the weights
  const MlpShape& s = a.shape;
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  const WarpNet net = stageNet<Weights>(s, a.w16, a.wout, reinterpret_cast<__half*>(smem), a.wOff,
    reinterpret_cast<float*>(smem + a.woutOff));
  __half* enc = reinterpret_cast<__half*>(smem + a.encOff) + warp * 16 * a.ldE;
  for (int i = lane; i < 16 * a.ldE; i += 32)
    enc[i] = __float2half(0.0f); // padding columns D..Dp-1 stay zero
  __syncthreads();

  const int g = lane >> 2, t = lane & 3;
  for (int64_t tile = int64_t(blockIdx.x) * Warps + warp; tile * 16 < n; tile += int64_t(gridDim.x) * Warps)
  {
    const int64_t o0 = tile * 16 + g, o1 = o0 + 8;
    // Where this lane's two outputs go: binned points carry their original index (loaded here, used at the end).
    int64_t d0 = o0, d1 = o1;
    if (a.binned && t == 0)
    {
      if (o0 < n)
        d0 = __float_as_uint(a.binned[o0].w);
      if (o1 < n)
        d1 = __float_as_uint(a.binned[o1].w);
    }
    __syncwarp(); // the previous tile's ldmatrix reads of enc are done
    WarpOut<W> out;
    if constexpr (Pre)
    {
      const PreEncoded src{ a.enc, tile * 16, a.sampleCount, a.liveCount ? n : -1 };
      warpForward<W, F, false, Weights>(a.grid, s, net, src, nullptr, enc, a.ldE, lane, NoStage{}, out);
    }
    else
    {
      float x[3];
      fwdPoint(a, tile * 16 + (lane & 15), x);
      const EncodeFrom<__half> src{ a.table16 };
      warpForward<W, F, false, Weights>(a.grid, s, net, src, x, enc, a.ldE, lane, NoStage{}, out);
    }
    if (t == 0)
    {
      if (o0 < n)
        a.out[d0] = out.lo;
      if (o1 < n)
        a.out[d1] = out.hi;
    }
  }
}

} // namespace gpu
} // namespace nv
