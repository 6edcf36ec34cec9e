// NeuralVolume engine: register-resident training kernel (forward, loss, backward, weight gradients) for W <= 64.
//
// A block of `Warps` warps takes T = 16 * Warps samples per iteration. Phase 1 has no block barrier: each warp
// encodes (or loads) its 16 samples, runs the forward pass with raw mma.sync m16n8k16 (the C fragment of layer k is
// the A fragment of layer k+1, as in GpuForward.cuh), the loss, and the backward pass to dL/d(encoding) with the
// transposed weights read by ldmatrix.trans. Every layer's input X_l and output gradient dZ_l go to shared staging
// rows (fp16) on the way. Phase 2 (after one barrier): the warps split the weight-gradient tiles
// dW_l = dZ_l^T X_l over the T samples, both operands through ldmatrix.trans, and keep them in registers for the
// whole kernel (flushed once per block). Arithmetic matches the WMMA kernel: fp16 operands, fp32 accumulation,
// fp16 rounding of each activation and of each dZ, output row in fp32.
#pragma once

#include "GpuWarpForward.cuh"
#include "GpuTrainArgs.cuh"

namespace nv
{
namespace gpu
{

constexpr int kRegTiles = 16; ///< weight-gradient tiles (16 x 8) per warp held in registers

/// C[:, n0 + 8j] += A(16 x 16, k = o0..o0+15) . Wl[o0:o0+16, n0 + 8j : +8] for j < nt (nt even, <= NT): the
/// backward product dZ . W with Wl row-major [o][i] in shared memory (ld ldw), B fragments by ldmatrix.trans.
template <int NT>
__device__ __forceinline__ void mmaChunkT(float (&C)[NT][4], const uint32_t (&A)[4], const __half* Wl, int ldw,
  int o0, int n0, int nt, int lane)
{
  const int q = lane >> 3, r = lane & 7;
  const __half* p = Wl + (o0 + (q & 1) * 8 + r) * ldw + n0 + (q >> 1) * 8;
#pragma unroll
  for (int j = 0; j < NT; j += 2)
  {
    if (j < nt)
    {
      uint32_t b[4];
      ldsm4<true>(b, p + j * 8);
      mma16816(C[j], A, b[0], b[1]);
      mma16816(C[j + 1], A, b[2], b[3]);
    }
  }
}

/// x * (mask > 0) for the two halves of a packed fp16 pair.
__device__ __forceinline__ float2 maskPositive(float x, float y, uint32_t mask)
{
  const __half2 m = *reinterpret_cast<const __half2*>(&mask);
  return make_float2(__low2float(m) > 0.0f ? x : 0.0f, __high2float(m) > 0.0f ? y : 0.0f);
}

/// Coordinates of training sample gi (0 beyond n).
__device__ __forceinline__ void trainPoint(const TrainArgs& a, int64_t gi, float x[3])
{
  x[0] = x[1] = x[2] = 0.0f;
  if (gi >= a.n)
    return;
  if (a.xyz)
  {
    x[0] = a.xyz[3 * gi];
    x[1] = a.xyz[3 * gi + 1];
    x[2] = a.xyz[3 * gi + 2];
  }
  else
  {
    randomPoint(a.seed, a.step, static_cast<uint64_t>(gi), x);
  }
}

/// Phase 1 for the warp's 16 rows: loss, dZ_l / X_l staging and dL/d(encoding) (global level-major or scatter).
template <int W, int F, bool Pre>
__device__ __forceinline__ void warpForwardBackward(const TrainArgs& a, unsigned char* smem, int64_t base, int row0,
  int lane, float gradScale, float (&woutAcc)[W / 8][2], float& lossAcc)
{
  const RegPlan& p = a.reg;
  const MlpShape& s = a.shape;
  __half* sh = reinterpret_cast<__half*>(smem);
  const float* swout = reinterpret_cast<const float*>(smem + p.wout);
  const int g = lane >> 2, t = lane & 3, r16 = lane & 15;
  __half* X0 = sh + p.x[0] + row0 * p.ldX0;

  // 1-3. Forward pass (encodings into X_0, X_l staged for the backward pass and the weight gradients), outputs.
  const WarpNet net{ sh, p.w, p.ldX0, p.ldA, swout };
  const StageActivations stage{ sh + row0 * p.ldA, p.x, p.ldA, nullptr, 0 };
  WarpOut<W> fo;
  if constexpr (Pre)
  {
    const PreEncoded src{ a.encG, base, a.n };
    warpForward<W, F, false, WeightsInShared>(a.grid, s, net, src, nullptr, X0, p.ldX0, lane, stage, fo);
  }
  else
  {
    float x[3];
    trainPoint(a, base + r16, x);
    const EncodeFrom<float> src{ a.table32 };
    warpForward<W, F, false, WeightsInShared>(a.grid, s, net, src, x, X0, p.ldX0, lane, stage, fo);
  }
  const float lo = fo.lo, hi = fo.hi;
  uint32_t(&XH)[W / 8][2] = fo.xh; // packed fp16 X_H: rows g / g + 8, columns 8j + 2t, +1
  float gr[2] = { 0.0f, 0.0f };
  {
    const float o[2] = { lo, hi };
#pragma unroll
    for (int k = 0; k < 2; ++k)
    {
      const int64_t gi = base + g + 8 * k;
      if (gi < a.n)
      {
        const float tg = a.targets[gi];
        if (!isnan(tg))
        {
          const float diff = o[k] - tg;
          if (a.l1)
          {
            gr[k] = diff > 0.0f ? 1.0f : (diff < 0.0f ? -1.0f : 0.0f);
            lossAcc += t == 0 ? fabsf(diff) : 0.0f;
          }
          else
          {
            gr[k] = 2.0f * diff * gradScale;
            lossAcc += t == 0 ? diff * diff : 0.0f;
          }
        }
      }
    }
  }

  // 4. dWout (registers) and dZ_{H-1} = (g * wout) masked by X_H > 0, rounded to fp16.
  uint32_t dA[W / 16][4];
#pragma unroll
  for (int j = 0; j < W / 8; ++j)
  {
    const __half2 h0 = *reinterpret_cast<const __half2*>(&XH[j][0]);
    const __half2 h1 = *reinterpret_cast<const __half2*>(&XH[j][1]);
    woutAcc[j][0] += gr[0] * __low2float(h0) + gr[1] * __low2float(h1);
    woutAcc[j][1] += gr[0] * __high2float(h0) + gr[1] * __high2float(h1);
    const float w0 = swout[8 * j + 2 * t], w1 = swout[8 * j + 2 * t + 1];
    const float2 d0 = maskPositive(gr[0] * w0, gr[0] * w1, XH[j][0]);
    const float2 d1 = maskPositive(gr[1] * w0, gr[1] * w1, XH[j][1]);
    dA[j / 2][(j & 1) * 2] = halves2(d0.x, d0.y);
    dA[j / 2][(j & 1) * 2 + 1] = halves2(d1.x, d1.y);
  }
  {
    __half* dz = sh + p.dz[s.H - 1] + row0 * p.ldA;
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
      storeFrag(dA[kc], dz, p.ldA, kc, lane);
  }

  // 5. Hidden layers: dX_l = dZ_l . W_l, dZ_{l-1} = dX_l masked by X_l > 0.
  for (int l = s.H - 1; l >= 1; --l)
  {
    float D[W / 8][4];
#pragma unroll
    for (int j = 0; j < W / 8; ++j)
      D[j][0] = D[j][1] = D[j][2] = D[j][3] = 0.0f;
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
      mmaChunkT<W / 8>(D, dA[kc], sh + p.w[l], p.ldA, kc * 16, 0, W / 8, lane);
    const __half* Xl = sh + p.x[l] + row0 * p.ldA;
    __half* dz = sh + p.dz[l - 1] + row0 * p.ldA;
#pragma unroll
    for (int j = 0; j < W / 8; ++j)
    {
      const uint32_t m0 = *reinterpret_cast<const uint32_t*>(Xl + g * p.ldA + 8 * j + 2 * t);
      const uint32_t m1 = *reinterpret_cast<const uint32_t*>(Xl + (g + 8) * p.ldA + 8 * j + 2 * t);
      const float2 d0 = maskPositive(D[j][0], D[j][1], m0);
      const float2 d1 = maskPositive(D[j][2], D[j][3], m1);
      dA[j / 2][(j & 1) * 2] = halves2(d0.x, d0.y);
      dA[j / 2][(j & 1) * 2 + 1] = halves2(d1.x, d1.y);
    }
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
      storeFrag(dA[kc], dz, p.ldA, kc, lane);
  }

  // 6. dL/d(encoding) = dZ_0 . W_0, 64 columns at a time.
  float* dEw = reinterpret_cast<float*>(smem + p.de) + row0 * p.ldDE; // fused mode only
  for (int n0 = 0; n0 < s.Dp; n0 += 64)
  {
    const int nt = min(8, (s.Dp - n0) / 8);
    float E[8][4];
#pragma unroll
    for (int j = 0; j < 8; ++j)
      E[j][0] = E[j][1] = E[j][2] = E[j][3] = 0.0f;
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
      mmaChunkT<8>(E, dA[kc], sh + p.w[0], p.ldX0, kc * 16, n0, nt, lane);
#pragma unroll
    for (int j = 0; j < 8; ++j)
    {
      const int c = n0 + 8 * j + 2 * t;
      if (j >= nt || c >= s.D)
        continue;
#pragma unroll
      for (int k = 0; k < 2; ++k)
      {
        const float e0 = E[j][2 * k], e1 = E[j][2 * k + 1];
        if constexpr (Pre)
        {
          const int64_t gi = base + g + 8 * k;
          if (gi >= a.n)
            continue;
          if constexpr (F == 1)
          {
            a.dEncG[c * a.n + gi] = e0;
            if (c + 1 < s.D)
              a.dEncG[(c + 1) * a.n + gi] = e1;
          }
          else
          {
            const int l = c / F, f = c % F;
            *reinterpret_cast<float2*>(a.dEncG + (l * a.n + gi) * F + f) = make_float2(e0, e1);
          }
        }
        else
        {
          float* d = dEw + (g + 8 * k) * p.ldDE + c;
          d[0] = e0;
          d[1] = e1;
        }
      }
    }
  }
  if constexpr (!Pre)
  {
    // Scatter: lane owns sample r16 and levels lane >> 4, +2, ...
    __syncwarp();
    const int64_t gi = base + r16;
    if (gi < a.n)
    {
      float x[3];
      trainPoint(a, gi, x);
      for (int l = lane >> 4; l < a.grid.levels; l += 2)
      {
        float d[F];
        bool any = false;
#pragma unroll
        for (int f = 0; f < F; ++f)
        {
          d[f] = dEw[r16 * p.ldDE + l * F + f];
          any |= d[f] != 0.0f;
        }
        if (!any)
          continue;
        const LevelInfo& lv = a.grid.level[l];
        uint32_t corner[3];
        float frac[3];
        gridPosition(lv, x, corner, frac);
        if (a.fixedTable)
          scatterCorners<F>(a.fixedTable, lv, corner, frac, d);
        else
          scatterCorners<F>(a.gradTable, lv, corner, frac, d);
      }
    }
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
  __half* sh = reinterpret_cast<__half*>(smem);
  // Weights (padded fp16, ld K + 8), output row, zeroed encoding padding, this warp's weight-gradient tiles.
  for (int l = 0; l < s.H; ++l)
  {
    const int K = s.inDim(l), kv = K / 8;
    const uint4* src = reinterpret_cast<const uint4*>(a.w16 + s.off[l]);
    __half* dst = sh + p.w[l];
    for (int i = threadIdx.x; i < s.W * kv; i += blockDim.x)
      *reinterpret_cast<uint4*>(dst + (i / kv) * (K + 8) + (i % kv) * 8) = src[i];
  }
  float* swout = reinterpret_cast<float*>(smem + p.wout);
  for (int i = threadIdx.x; i < s.W; i += blockDim.x)
    swout[i] = a.wout[i];
  for (int i = threadIdx.x; i < T * p.ldX0; i += blockDim.x)
    sh[p.x[0] + i] = __float2half(0.0f);
  __syncthreads();

  // Weight-gradient tiles of this warp: row groups (layer, 16 outputs) w, w + Warps, ..., all column tiles;
  // descriptor = layer | first output << 4 | first input << 12.
  __shared__ int sdesc[Warps * kRegTiles];
  int nTiles = 0;
  {
    const int groups = s.H * (W / 16);
    for (int rg = warp; rg < groups; rg += Warps)
    {
      const int l = rg / (W / 16), m0 = (rg % (W / 16)) * 16, nt = s.inDim(l) / 8;
      for (int j = 0; j < nt; ++j, ++nTiles)
        if (lane == 0)
          sdesc[warp * kRegTiles + nTiles] = l | (m0 << 4) | ((8 * j) << 12);
    }
  }
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

  const float gradScale = lossGradScale(a.prev, a.l1);
  if (blockIdx.x == 0 && threadIdx.x == 0)
    a.counters->gradScale = gradScale;
  const int q8 = lane >> 3, r8 = lane & 7;
  for (int64_t it = blockIdx.x; it * T < a.n; it += gridDim.x)
  {
    warpForwardBackward<W, F, Pre>(a, smem, it * T + warp * 16, warp * 16, lane, gradScale, woutAcc, lossAcc);
    __syncthreads();
    if (s.Dp == W)
    {
      // Every layer has W / 8 column tiles: row group r of this warp owns tiles r * W / 8 + j (as the descriptors).
#pragma unroll
      for (int r = 0; r < kRegTiles / (W / 8); ++r)
      {
        const int rg = warp + r * Warps;
        if (rg < s.H * (W / 16))
        {
          const int l = rg / (W / 16), m0 = (rg % (W / 16)) * 16;
          const __half* dz = sh + p.dz[l] + m0 + (q8 & 1) * 8 + ((q8 >> 1) * 8 + r8) * p.ldA;
          const __half* X = sh + p.x[l] + (q8 * 8 + r8) * p.ldA; // ldX0 == ldA here
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
    else
    {
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
              const __half* dz = sh + p.dz[l] + m0 + (q8 & 1) * 8;
              ldsm4<true>(a0, dz + (k0 + (q8 >> 1) * 8 + r8) * p.ldA);
              ldsm4<true>(a1, dz + (k0 + 16 + (q8 >> 1) * 8 + r8) * p.ldA);
              rgPrev = rg;
            }
            const int ldx = l == 0 ? p.ldX0 : p.ldA;
            uint32_t b[4];
            ldsm4<true>(b, sh + p.x[l] + (k0 + q8 * 8 + r8) * ldx + n0);
            mma16816(acc[q], a0, b[0], b[1]);
            mma16816(acc[q], a1, b[2], b[3]);
          }
        }
      }
    }
    __syncthreads();
  }

  // Flush: weight gradients (padded layout), output row, loss.
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
      fixedAdd(a.fixedMlp + s.off[s.H] + 8 * j + 2 * t, woutAcc[j][0]);
      fixedAdd(a.fixedMlp + s.off[s.H] + 8 * j + 2 * t + 1, woutAcc[j][1]);
    }
    else if (g == 0)
      atomicAddPair(a.gradPad + s.off[s.H] + 8 * j + 2 * t, woutAcc[j][0], woutAcc[j][1]);
  }
  for (int o = 16; o > 0; o >>= 1)
    lossAcc += __shfl_xor_sync(0xffffffffu, lossAcc, o);
  if (lane == 0)
    addLoss(a, lossAcc);
}

/// Shared-memory plan of trainRegKernel for blocks of `warps` warps (fused: + per-warp dEnc); total 0 when the
/// shape is not covered (W > 64, too many weight-gradient tiles for a warp's registers).
inline RegPlan makeRegPlan(const MlpShape& s, int warps, bool fused)
{
  RegPlan p{};
  if (s.W > 64 || s.H < 1 || s.H > kMaxHidden)
    return p;
  // Most tiles a warp gets: row groups warp, warp + warps, ... of (layer, 16 outputs), inDim(l) / 8 tiles each.
  const int groups = s.H * (s.W / 16);
  for (int w = 0; w < warps; ++w)
  {
    int n = 0;
    for (int rg = w; rg < groups; rg += warps)
      n += s.inDim(rg / (s.W / 16)) / 8;
    if (n > kRegTiles)
      return p;
  }
  const size_t T = size_t(16) * warps;
  p.warps = warps;
  p.ldX0 = s.Dp + 8;
  p.ldA = s.W + 8;
  p.ldDE = s.Dp + 4;
  size_t h = 0; // halves
  for (int l = 0; l < s.H; ++l)
  {
    p.w[l] = static_cast<int>(h);
    h += size_t(s.W) * (s.inDim(l) + 8);
  }
  for (int l = 0; l < s.H; ++l)
  {
    p.x[l] = static_cast<int>(h);
    h += T * (l == 0 ? p.ldX0 : p.ldA);
  }
  for (int l = 0; l < s.H; ++l)
  {
    p.dz[l] = static_cast<int>(h);
    h += T * p.ldA;
  }
  size_t o = roundUp128(h * 2);
  p.wout = static_cast<int>(o);
  o += roundUp128(size_t(s.W) * 4);
  p.de = static_cast<int>(o);
  if (fused)
    o += T * p.ldDE * 4;
  p.total = static_cast<int>(o);
  return p;
}

} // namespace gpu
} // namespace nv
