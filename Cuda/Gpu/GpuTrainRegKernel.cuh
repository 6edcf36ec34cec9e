// NeuralVolume engine: register-resident training kernel (forward, loss, backward, weight gradients) for W <= 64.
//
// A block of `Warps` warps takes T = 16 * Warps samples per iteration. Phase 1 has no block barrier: each warp
// encodes (or loads) its 16 samples, runs the forward pass with raw mma.sync m16n8k16 (the C fragment of layer k is
// the A fragment of layer k+1, as in GpuForward.cuh), the loss, and the backward pass to dL/d(encoding) with the
// transposed weights read by ldmatrix.trans (GpuWarpForwardBackward.cuh). Every layer's input X_l and output
// gradient dZ_l go to shared staging rows (fp16) on the way. Phase 2 (after one barrier): the warps split the
// weight-gradient tiles dW_l = dZ_l^T X_l over the T samples, both operands through ldmatrix.trans, and keep them
// in registers for the whole kernel (flushed once per block). Arithmetic matches the WMMA kernel: fp16 operands,
// fp32 accumulation, fp16 rounding of each activation and of each dZ, output row in fp32.
#pragma once

#include "GpuWarpForwardBackward.cuh"

namespace nv
{
namespace gpu
{

constexpr int kRegTiles = 16; ///< weight-gradient tiles (16 x 8) per warp held in registers

/// The block's shared memory before the first tile: the weights (padded fp16, ld K + 8), the output row and the
/// zeroed X_0 staging (its padding columns stay zero).
template <int Warps>
__device__ __forceinline__ void stageRegKernelInputs(const TrainArgs& a, unsigned char* smem)
{
  const RegPlan& p = a.reg;
  const MlpShape& s = a.shape;
  constexpr int T = 16 * Warps;
  __half* sh = reinterpret_cast<__half*>(smem);
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    const int K = s.inDim(l), kv = K / 8;
    const uint4* src = reinterpret_cast<const uint4*>(a.w16 + s.off[l]);
    __half* dst = sh + p.weights[l];
    for (int i = threadIdx.x; i < s.width * kv; i += blockDim.x)
      *reinterpret_cast<uint4*>(dst + (i / kv) * (K + 8) + (i % kv) * 8) = src[i];
  }
  float* swout = reinterpret_cast<float*>(smem + p.wout);
  for (int i = threadIdx.x; i < s.width; i += blockDim.x)
    swout[i] = a.wout[i];
  for (int i = threadIdx.x; i < T * p.ldX0; i += blockDim.x)
    sh[p.layerInputs[0] + i] = __float2half(0.0f);
}

/// Weight-gradient tiles of this warp: row groups (layer, 16 outputs) warp, warp + Warps, ..., all column tiles,
/// written to the warp's kRegTiles descriptors in sdesc (lane 0; descriptor = layer | first output << 4 | first
/// input << 12). Returns the warp's tile count.
template <int W, int Warps>
__device__ __forceinline__ int assignWeightGradTiles(const MlpShape& s, int* sdesc, int warp, int lane)
{
  int nTiles = 0;
  const int groups = s.hiddenLayers * (W / 16);
  for (int rg = warp; rg < groups; rg += Warps)
  {
    const int l = rg / (W / 16), m0 = (rg % (W / 16)) * 16, nt = s.inDim(l) / 8;
    for (int j = 0; j < nt; ++j, ++nTiles)
      if (lane == 0)
        sdesc[warp * kRegTiles + nTiles] = l | (m0 << 4) | ((8 * j) << 12);
  }
  return nTiles;
}

/// Phase 2 when every layer has W / 8 column tiles (paddedInputs == W): row group r of this warp owns tiles
/// r * W / 8 + j (as the descriptors); acc += dZ_l^T X_l over the block's T samples. q8 = lane >> 3, r8 = lane & 7,
/// computed once by the kernel (recomputed here, they changed the width-16 kernels' code).
template <int W, int Warps>
__device__ __forceinline__ void accumulateSquareWeightGrads(const RegPlan& p, const MlpShape& s, const __half* sh,
  int warp, int q8, int r8, float (&acc)[kRegTiles][4])
{
  constexpr int T = 16 * Warps;
#pragma unroll
  for (int r = 0; r < kRegTiles / (W / 8); ++r)
  {
    const int rg = warp + r * Warps;
    if (rg < s.hiddenLayers * (W / 16))
    {
      const int l = rg / (W / 16), m0 = (rg % (W / 16)) * 16;
      const __half* dz = sh + p.layerOutputGrads[l] + m0 + (q8 & 1) * 8 + ((q8 >> 1) * 8 + r8) * p.ldA;
      const __half* X = sh + p.layerInputs[l] + (q8 * 8 + r8) * p.ldA; // ldX0 == ldA here
      for (int k0 = 0; k0 < T; k0 += 32)
      {
        uint32_t a0[4], a1[4];
        ldsm4<true>(a0, dz + k0 * p.ldA);
        ldsm4<true>(a1, dz + (k0 + 16) * p.ldA);
#pragma unroll
        for (int j = 0; j < W / 8; ++j)
        {
          uint32_t b[4];
          ldsm4<true>(b, X + k0 * p.ldA + 8 * j);
          mma16816(acc[r * (W / 8) + j], a0, b[0], b[1]);
          mma16816(acc[r * (W / 8) + j], a1, b[2], b[3]);
        }
      }
    }
  }
}

/// Flush of the hidden layers' weight gradients (padded layout): atomics, or fixed point in deterministic mode.
__device__ __forceinline__ void flushWeightGradTiles(const TrainArgs& a, const int* desc, int nTiles, int lane,
  const float (&acc)[kRegTiles][4])
{
  const MlpShape& s = a.shape;
  const int g = lane >> 2, t = lane & 3;
#pragma unroll
  for (int q = 0; q < kRegTiles; ++q)
  {
    if (q < nTiles)
    {
      const int dq = desc[q], l = dq & 15, m0 = (dq >> 4) & 0xff, n0 = dq >> 12, K = s.inDim(l);
      const size_t o = s.off[l] + (m0 + g) * K + n0 + 2 * t;
      if (a.fixedMlp)
      {
        Fixed* d = a.fixedMlp + o;
        fixedAdd(d, acc[q][0]);
        fixedAdd(d + 1, acc[q][1]);
        fixedAdd(d + 8 * K, acc[q][2]);
        fixedAdd(d + 8 * K + 1, acc[q][3]);
        continue;
      }
      float* d = a.gradPad + o;
      atomicAddPair(d, acc[q][0], acc[q][1]);
      atomicAddPair(d + 8 * K, acc[q][2], acc[q][3]);
    }
  }
}

/// The output row's gradient: sums over the row groups (lanes of equal lane & 3), added by row group 0.
template <int W>
__device__ __forceinline__ void flushOutputRowGrads(const TrainArgs& a, int lane, float (&woutAcc)[W / 8][2])
{
  const MlpShape& s = a.shape;
  const int g = lane >> 2, t = lane & 3;
#pragma unroll
  for (int j = 0; j < W / 8; ++j)
  {
#pragma unroll
    for (int e = 0; e < 2; ++e)
    {
      float v = woutAcc[j][e];
      v += __shfl_xor_sync(0xffffffffu, v, 4);
      v += __shfl_xor_sync(0xffffffffu, v, 8);
      v += __shfl_xor_sync(0xffffffffu, v, 16);
      woutAcc[j][e] = v;
    }
    if (g == 0 && a.fixedMlp)
    {
      fixedAdd(a.fixedMlp + s.off[s.hiddenLayers] + 8 * j + 2 * t, woutAcc[j][0]);
      fixedAdd(a.fixedMlp + s.off[s.hiddenLayers] + 8 * j + 2 * t + 1, woutAcc[j][1]);
    }
    else if (g == 0)
      atomicAddPair(a.gradPad + s.off[s.hiddenLayers] + 8 * j + 2 * t, woutAcc[j][0], woutAcc[j][1]);
  }
}

template <int W, int F, int Warps, bool Pre>
__global__ void __launch_bounds__(Warps * 32, 1) trainRegKernel(const __grid_constant__ TrainArgs a)
{
  extern __shared__ __align__(128) unsigned char smem[];
  const RegPlan& p = a.reg;
  const MlpShape& s = a.shape;
  constexpr int T = 16 * Warps;
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  const __half* sh = reinterpret_cast<const __half*>(smem);
  stageRegKernelInputs<Warps>(a, smem);
  __syncthreads();

  __shared__ int sdesc[Warps * kRegTiles];
  const int nTiles = assignWeightGradTiles<W, Warps>(s, sdesc, warp, lane);
  __syncwarp();
  const int* desc = sdesc + warp * kRegTiles;
  float acc[kRegTiles][4];
#pragma unroll
  for (int q = 0; q < kRegTiles; ++q)
    acc[q][0] = acc[q][1] = acc[q][2] = acc[q][3] = 0.0f;
  float woutAcc[W / 8][2];
#pragma unroll
  for (int j = 0; j < W / 8; ++j)
    woutAcc[j][0] = woutAcc[j][1] = 0.0f;
  float lossAcc = 0.0f;

  const float gradScale = publishGradScale(a);
  const int q8 = lane >> 3, r8 = lane & 7;
  for (int64_t it = blockIdx.x; it * T < a.sampleCount; it += gridDim.x)
  {
    warpForwardBackward<W, F, Pre>(a, smem, it * T + warp * 16, warp * 16, lane, gradScale, woutAcc, lossAcc);
    __syncthreads();
    if (s.paddedInputs == W)
      accumulateSquareWeightGrads<W, Warps>(p, s, sh, warp, q8, r8, acc);
    else
    {
      // Any shape: the warp's tiles by their descriptors. Inline here: as a helper (acc by reference) it changed the
      // kernels' SASS, whether q8 / r8 were recomputed or passed.
      for (int k0 = 0; k0 < T; k0 += 32)
      {
        uint32_t a0[4], a1[4]; // dZ_l^T fragments, reloaded when the row group changes (tiles are row-group major)
        int rgPrev = -1;
#pragma unroll
        for (int q = 0; q < kRegTiles; ++q)
        {
          if (q < nTiles)
          {
            const int d = desc[q], l = d & 15, m0 = (d >> 4) & 0xff, n0 = d >> 12, rg = d & 0xfff;
            if (rg != rgPrev)
            {
              const __half* dz = sh + p.layerOutputGrads[l] + m0 + (q8 & 1) * 8;
              ldsm4<true>(a0, dz + (k0 + (q8 >> 1) * 8 + r8) * p.ldA);
              ldsm4<true>(a1, dz + (k0 + 16 + (q8 >> 1) * 8 + r8) * p.ldA);
              rgPrev = rg;
            }
            const int ldx = l == 0 ? p.ldX0 : p.ldA;
            uint32_t b[4];
            ldsm4<true>(b, sh + p.layerInputs[l] + (k0 + q8 * 8 + r8) * ldx + n0);
            mma16816(acc[q], a0, b[0], b[1]);
            mma16816(acc[q], a1, b[2], b[3]);
          }
        }
      }
    }
    __syncthreads();
  }

  // Flush: weight gradients (padded layout), output row, loss.
  flushWeightGradTiles(a, desc, nTiles, lane, acc);
  flushOutputRowGrads<W>(a, lane, woutAcc);
  addWarpLoss(a, lane, lossAcc);
}

/// Shared-memory plan of trainRegKernel for blocks of `warps` warps (fused: + per-warp dEnc); total 0 when the
/// shape is not covered (W > 64, too many weight-gradient tiles for a warp's registers).
inline RegPlan makeRegPlan(const MlpShape& s, int warps, bool fused)
{
  RegPlan p{};
  if (s.width > 64 || s.hiddenLayers < 1 || s.hiddenLayers > kMaxHidden)
    return p;
  // Most tiles a warp gets: row groups warp, warp + warps, ... of (layer, 16 outputs), inDim(l) / 8 tiles each.
  const int groups = s.hiddenLayers * (s.width / 16);
  for (int w = 0; w < warps; ++w)
  {
    int n = 0;
    for (int rg = w; rg < groups; rg += warps)
      n += s.inDim(rg / (s.width / 16)) / 8;
    if (n > kRegTiles)
      return p;
  }
  const size_t T = size_t(16) * warps;
  p.warps = warps;
  p.ldX0 = s.paddedInputs + 8;
  p.ldA = s.width + 8;
  p.ldDE = s.paddedInputs + 4;
  size_t h = 0; // halves
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    p.weights[l] = static_cast<int>(h);
    h += size_t(s.width) * (s.inDim(l) + 8);
  }
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    p.layerInputs[l] = static_cast<int>(h);
    h += T * (l == 0 ? p.ldX0 : p.ldA);
  }
  for (int l = 0; l < s.hiddenLayers; ++l)
  {
    p.layerOutputGrads[l] = static_cast<int>(h);
    h += T * p.ldA;
  }
  size_t o = roundUp128(h * 2);
  p.wout = static_cast<int>(o);
  o += roundUp128(size_t(s.width) * 4);
  p.encodingGrads = static_cast<int>(o);
  if (fused)
    o += T * p.ldDE * 4;
  p.total = static_cast<int>(o);
  return p;
}

} // namespace gpu
} // namespace nv
