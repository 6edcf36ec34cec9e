// NeuralVolume engine: the general training kernel (any width up to 128, weights in shared memory or read through
// L1). One block takes T = 16 * warps samples per tile: the forward pass per warp (GpuWarpForward.cuh, activations
// staged in shared memory), loss, backward with WMMA m16n16k16, weight gradients into a per-block slot, and the
// table-gradient scatter (or dEnc out for the level-major scatter). The register-resident kernel
// (GpuTrainRegKernel.cuh) replaces it where the shape allows.
#pragma once

#include "GpuTrainArgs.cuh"
#include "GpuWarpForward.cuh"

namespace nv
{
namespace gpu
{

/// The encoding rows' padding columns (inputs .. paddedInputs) are zeroed once and stay zero.
__device__ __forceinline__ void zeroEncodingPadding(const SmemPlan& p, const MlpShape& s, __half* enc, int T)
{
  const int pad = s.paddedInputs - s.inputs;
  for (int i = threadIdx.x; i < T * pad; i += blockDim.x)
    enc[(i / pad) * p.ldE + s.inputs + i % pad] = __float2half(0.0f);
}

/// The tile's coordinates (sx) and targets (stgt; NaN beyond the batch) into shared memory.
template <bool TwoPass>
__device__ __forceinline__ void loadTileSamples(const TrainArgs& a, int64_t base, int valid, int T, float* sx,
  float* stgt)
{
  for (int t = threadIdx.x; t < T; t += blockDim.x)
  {
    float x[3] = { 0.0f, 0.0f, 0.0f };
    float tg = __int_as_float(0x7fc00000);
    if (t < valid)
    {
      const int64_t gi = base + t;
      if (TwoPass)
      {
        // no coordinates needed: the level-major encode and scatter passes regenerate them
      }
      else if (a.xyz)
      {
        x[0] = a.xyz[3 * gi];
        x[1] = a.xyz[3 * gi + 1];
        x[2] = a.xyz[3 * gi + 2];
      }
      else
      {
        randomPoint(a.seed, a.step, static_cast<uint64_t>(gi), x);
      }
      tg = a.targets[gi];
    }
    sx[3 * t] = x[0];
    sx[3 * t + 1] = x[1];
    sx[3 * t + 2] = x[2];
    stgt[t] = tg;
  }
}

/// Forward: the warp's 16 rows (the one forward pass) from the encodings in enc, X_l and X_H staged in acts for the
/// backward pass, the outputs into sg.
template <int W, int F, bool TwoPass>
__device__ __forceinline__ void wmmaWarpForward(const TrainArgs& a, const unsigned char* smem, const float* sw,
  const float* sx, __half* enc, __half* acts, int actStride, int64_t base, int row0, int lane, float* sg)
{
  const SmemPlan& p = a.plan;
  const MlpShape& s = a.shape;
  const WarpNet net = p.wInSmem
    ? WarpNet{ reinterpret_cast<const __half*>(smem + p.weights), p.wOff, s.paddedInputs + 8, W + 8, sw }
    : WarpNet{ a.w16, s.off, s.paddedInputs, W, sw };
  // X_l of layer l >= 1 is the output of layer l - 1: activation slot l - 1 (a.actOff[l] = (l - 1) * actStride).
  const StageActivations st{ acts + row0 * p.ldA, a.actOff, p.ldA,
    acts + (s.hiddenLayers - 1) * actStride + row0 * p.ldA, p.ldA };
  __half* rows = enc + row0 * p.ldE;
  WarpOut<W> fo;
  if constexpr (TwoPass)
  {
    const PreEncoded src{ a.encG, base + row0, a.sampleCount };
    if (p.wInSmem)
      warpForward<W, F, false, WeightsInShared>(a.grid, s, net, src, nullptr, rows, p.ldE, lane, st, fo);
    else
      warpForward<W, F, false, WeightsInGlobal>(a.grid, s, net, src, nullptr, rows, p.ldE, lane, st, fo);
  }
  else
  {
    const float* xr = sx + 3 * (row0 + (lane & 15));
    const float x[3] = { xr[0], xr[1], xr[2] };
    const EncodeFrom<__half> src{ a.table16 };
    if (p.wInSmem)
      warpForward<W, F, false, WeightsInShared>(a.grid, s, net, src, x, rows, p.ldE, lane, st, fo);
    else
      warpForward<W, F, false, WeightsInGlobal>(a.grid, s, net, src, x, rows, p.ldE, lane, st, fo);
  }
  if ((lane & 3) == 0)
  {
    sg[row0 + (lane >> 2)] = fo.lo; // outputs first; the loss turns them into gradients
    sg[row0 + (lane >> 2) + 8] = fo.hi;
  }
}

/// The loss of the warp's 16 rows into lossAcc and their output gradients in sg in place of the outputs (L2: times
/// gradScale; L1: +-1; 0 for NaN targets).
__device__ __forceinline__ void wmmaWarpLoss(const TrainArgs& a, float* sg, const float* stgt, int row0, int lane,
  float gradScale, float& lossAcc)
{
  const int t = row0 + (lane >> 1), h = lane & 1;
  const float o = sg[t];
  __syncwarp();
  if (h == 0)
  {
    const float tg = stgt[t];
    float g = 0.0f;
    if (!isnan(tg))
    {
      const float diff = o - tg;
      if (a.l1)
      {
        lossAcc += fabsf(diff);
        g = diff > 0.0f ? 1.0f : (diff < 0.0f ? -1.0f : 0.0f);
      }
      else
      {
        lossAcc += diff * diff;
        g = 2.0f * diff * gradScale;
      }
    }
    sg[t] = g; // unscaled: the 1/nValid factor is applied by Adam (keeps fp16 gradients in range)
  }
}

/// The output layer: the warp's dZ_{H-1} = g * wout masked by X_H > 0 (fp16, into dz), and, after the block barrier,
/// the output row's gradient over the tile into the slot.
template <int W>
__device__ __forceinline__ void wmmaOutputLayerBackward(const SmemPlan& p, const MlpShape& s, const __half* AH,
  const float* sg, const float* sw, __half* dz, int T, int row0, int lane, float* slot, bool first)
{
  for (int e = lane; e < 16 * W; e += 32)
  {
    const int t = row0 + e / W, o = e % W;
    const float av = __half2float(AH[t * p.ldA + o]);
    dz[t * p.ldA + o] = __float2half_rn(av > 0.0f ? sg[t] * sw[o] : 0.0f);
  }
  __syncthreads();
  for (int o = threadIdx.x; o < W; o += blockDim.x)
  {
    float acc = 0.0f;
    for (int t = 0; t < T; ++t)
      acc += sg[t] * __half2float(AH[t * p.ldA + o]);
    float* d = slot + s.off[s.hiddenLayers] + o;
    *d = first ? acc : *d + acc;
  }
}

/// The tile's dEnc: level-major to global memory (two-pass) or scattered into the table gradient.
template <int F, bool TwoPass>
__device__ __forceinline__ void wmmaEncodingGradients(const TrainArgs& a, const SmemPlan& p, int T, int64_t base,
  int valid, const float* sx, const float* dEnc)
{
  if constexpr (TwoPass)
  {
    for (int it = threadIdx.x; it < T * a.grid.levels; it += blockDim.x)
    {
      const int t = it % T, l = it / T;
      if (t < valid)
      {
        float* d = a.dEncG + (l * a.sampleCount + base + t) * F;
#pragma unroll
        for (int f = 0; f < F; ++f)
          d[f] = dEnc[t * p.ldDE + l * F + f];
      }
    }
  }
  else
  {
    if (a.fixedTable)
      scatterTile<F>(a.grid, a.fixedTable, sx, dEnc, p.ldDE, T, valid);
    else
      scatterTile<F>(a.grid, a.gradTable, sx, dEnc, p.ldDE, T, valid);
  }
}

/// The block's slot into the step's MLP gradient: fixed point in deterministic mode, else float atomics.
__device__ __forceinline__ void flushBlockSlot(const TrainArgs& a, const float* slot)
{
  const MlpShape& s = a.shape;
  if (a.fixedMlp)
  {
    for (int i = threadIdx.x; i < s.total; i += blockDim.x)
      fixedAdd(a.fixedMlp + i, slot[i]);
    return;
  }
  const float4* src = reinterpret_cast<const float4*>(slot);
  for (int i = threadIdx.x; i < s.total / 4; i += blockDim.x)
  {
    const float4 v = src[i];
    atomicAddQuad(a.gradPad + 4 * i, v.x, v.y, v.z, v.w);
  }
}

template <int W, int F, bool TwoPass>
__global__ void __launch_bounds__(256) trainWmmaKernel(const __grid_constant__ TrainArgs a)
{
  extern __shared__ __align__(128) unsigned char smem[];
  const SmemPlan& p = a.plan;
  const MlpShape& s = a.shape;
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31, T = p.tileSamples, warps = p.warps;
  float* sx = reinterpret_cast<float*>(smem + p.xyz);
  float* stgt = reinterpret_cast<float*>(smem + p.targets);
  float* sg = reinterpret_cast<float*>(smem + p.outputGrads);
  __half* enc = reinterpret_cast<__half*>(smem + p.enc);
  __half* acts = reinterpret_cast<__half*>(smem + p.acts);
  float* dEnc = reinterpret_cast<float*>(smem + p.acts); // alias: written when the activations are dead
  __half* dzBuf[2] = { reinterpret_cast<__half*>(smem + p.dz0), reinterpret_cast<__half*>(smem + p.dz1) };
  float* stage = reinterpret_cast<float*>(smem + p.stage) + warp * 256;
  const float* sw = reinterpret_cast<const float*>(smem + p.wout);
  const __half* wl[kMaxHidden];
  int ldw[kMaxHidden];
  stageWeights(s, p, smem, a.w16, a.wout, wl, ldw);
  zeroEncodingPadding(p, s, enc, T);
  __syncthreads();
  float* slot = a.slots + size_t(blockIdx.x) * s.total;
  const int row0 = warp * 16;
  const int actStride = T * p.ldA;
  bool first = true;
  float lossAcc = 0.0f;
  const float gradScale = publishGradScale(a);
  for (int tile = blockIdx.x; tile < a.tiles; tile += gridDim.x)
  {
    const int64_t base = int64_t(tile) * T;
    const int valid = static_cast<int>(min(int64_t(T), a.sampleCount - base));
    loadTileSamples<TwoPass>(a, base, valid, T, sx, stgt);
    __syncthreads();
    wmmaWarpForward<W, F, TwoPass>(a, smem, sw, sx, enc, acts, actStride, base, row0, lane, sg);
    __syncwarp();
    const __half* AH = acts + (s.hiddenLayers - 1) * actStride;
    wmmaWarpLoss(a, sg, stgt, row0, lane, gradScale, lossAcc);
    __syncwarp();
    wmmaOutputLayerBackward<W>(p, s, AH, sg, sw, dzBuf[0], T, row0, lane, slot, first);
    int cur = 0;
    for (int l = s.hiddenLayers - 1; l >= 0; --l)
    {
      __syncthreads();
      const __half* X = l == 0 ? enc : acts + (l - 1) * actStride;
      const int ldX = l == 0 ? p.ldE : p.ldA;
      const int K = s.inDim(l);
      weightGrad<W>(dzBuf[cur], p.ldA, X, ldX, K, T, slot + s.off[l], first, warp, warps);
      if (l > 0)
        backwardInput<W>(dzBuf[cur], p.ldA, wl[l], ldw[l], K, row0, lane, stage, X, dzBuf[cur ^ 1], p.ldA, nullptr, 0);
      else
        backwardInput<W>(dzBuf[cur], p.ldA, wl[0], ldw[0], K, row0, lane, stage, nullptr, nullptr, 0, dEnc, p.ldDE);
      cur ^= 1;
    }
    __syncthreads();
    wmmaEncodingGradients<F, TwoPass>(a, p, T, base, valid, sx, dEnc);
    __syncthreads();
    first = false;
  }
  addWarpLoss(a, lane, lossAcc);
  if (!first)
  {
    __syncthreads();
    flushBlockSlot(a, slot);
  }
}

} // namespace gpu
} // namespace nv
