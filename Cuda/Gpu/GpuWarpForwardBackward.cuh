// NeuralVolume engine: phase 1 of the register-resident training kernel (GpuTrainRegKernel.cuh) for one warp's 16
// samples, without a block barrier: encode (or load) the samples, the forward pass with raw mma.sync m16n8k16 (the
// C fragment of layer k is the A fragment of layer k+1, as in GpuForward.cuh), the loss, and the backward pass to
// dL/d(encoding) with the transposed weights read by ldmatrix.trans. Every layer's input X_l and output gradient
// dZ_l go to shared staging rows (fp16) for phase 2, the weight gradients.
#pragma once

#include "GpuWarpForward.cuh"
#include "GpuTrainArgs.cuh"

namespace nv
{
namespace gpu
{

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
  if (gi >= a.sampleCount)
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

/// 3. The loss gradient of the lane's two outputs (rows g and g + 8), times gradScale for L2 (L1: +-1), and the
/// loss into lossAcc (one lane of four adds it). Samples beyond n and NaN targets give 0.
__device__ __forceinline__ void warpLossGradient(const TrainArgs& a, int64_t base, int lane, float gradScale,
  float lo, float hi, float (&gr)[2], float& lossAcc)
{
  const int g = lane >> 2, t = lane & 3;
  const float o[2] = { lo, hi };
#pragma unroll
  for (int k = 0; k < 2; ++k)
  {
    const int64_t gi = base + g + 8 * k;
    if (gi < a.sampleCount)
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

/// 4. dWout (registers) and dZ_{H-1} = (g * wout) masked by X_H > 0, rounded to fp16: the A fragments dA, also
/// staged in shared memory for the weight gradients.
template <int W>
__device__ __forceinline__ void outputLayerBackward(const RegPlan& p, const MlpShape& s, __half* sh,
  const float* swout, int row0, int lane, const uint32_t (&XH)[W / 8][2], const float (&gr)[2],
  float (&woutAcc)[W / 8][2], uint32_t (&dA)[W / 16][4])
{
  const int t = lane & 3;
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
  __half* dz = sh + p.layerOutputGrads[s.hiddenLayers - 1] + row0 * p.ldA;
#pragma unroll
  for (int kc = 0; kc < W / 16; ++kc)
    storeFrag(dA[kc], dz, p.ldA, kc, lane);
}

/// 5. Hidden layers: dX_l = dZ_l . W_l, dZ_{l-1} = dX_l masked by X_l > 0 (dA in, dZ_0 out), each staged.
template <int W>
__device__ __forceinline__ void hiddenLayersBackward(const RegPlan& p, const MlpShape& s, __half* sh, int row0,
  int lane, uint32_t (&dA)[W / 16][4])
{
  const int g = lane >> 2, t = lane & 3;
  for (int l = s.hiddenLayers - 1; l >= 1; --l)
  {
    float D[W / 8][4];
#pragma unroll
    for (int j = 0; j < W / 8; ++j)
      D[j][0] = D[j][1] = D[j][2] = D[j][3] = 0.0f;
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
      mmaChunkT<W / 8>(D, dA[kc], sh + p.weights[l], p.ldA, kc * 16, 0, W / 8, lane);
    const __half* Xl = sh + p.layerInputs[l] + row0 * p.ldA;
    __half* dz = sh + p.layerOutputGrads[l - 1] + row0 * p.ldA;
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
}

/// Fused mode: the warp's dEnc rows into the table gradient. The lane owns sample r16 and levels lane >> 4, +2, ...
template <int F>
__device__ __forceinline__ void scatterEncodingGradient(const TrainArgs& a, const float* dEw, int64_t base, int lane)
{
  const RegPlan& p = a.reg;
  const int r16 = lane & 15;
  const int64_t gi = base + r16;
  if (gi >= a.sampleCount)
    return;
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

/// 1-3. The forward pass of the warp's 16 rows: the encodings into X_0, every X_l staged for the backward pass and
/// the weight gradients, the outputs (and X_H) in fo.
template <int W, int F, bool Pre>
__device__ __forceinline__ WarpOut<W> regWarpForward(const TrainArgs& a, __half* sh, const float* swout,
  int64_t base, int row0, int lane)
{
  const RegPlan& p = a.reg;
  const MlpShape& s = a.shape;
  __half* X0 = sh + p.layerInputs[0] + row0 * p.ldX0;
  const WarpNet net{ sh, p.weights, p.ldX0, p.ldA, swout };
  const StageActivations stage{ sh + row0 * p.ldA, p.layerInputs, p.ldA, nullptr, 0 };
  WarpOut<W> fo;
  if constexpr (Pre)
  {
    const PreEncoded src{ a.encG, base, a.sampleCount };
    warpForward<W, F, false, WeightsInShared>(a.grid, s, net, src, nullptr, X0, p.ldX0, lane, stage, fo);
  }
  else
  {
    float x[3];
    trainPoint(a, base + (lane & 15), x);
    const EncodeFrom<float> src{ a.table32 };
    warpForward<W, F, false, WeightsInShared>(a.grid, s, net, src, x, X0, p.ldX0, lane, stage, fo);
  }
  return fo;
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
  const WarpOut<W> fo = regWarpForward<W, F, Pre>(a, sh, swout, base, row0, lane);
  float gr[2] = { 0.0f, 0.0f };
  warpLossGradient(a, base, lane, gradScale, fo.lo, fo.hi, gr, lossAcc);

  uint32_t dA[W / 16][4];
  outputLayerBackward<W>(p, s, sh, swout, row0, lane, fo.xh, gr, woutAcc, dA);
  hiddenLayersBackward<W>(p, s, sh, row0, lane, dA);

  // 6. dL/d(encoding) = dZ_0 . W_0, 64 columns at a time (inline here: as a helper it changed the fused kernels'
  // register counts, and a helper for one lane's store pair raised 9 of the 24 instances' by up to 6), level-major
  // to global memory (Pre) or to the warp's dEnc rows for the scatter.
  const int g = lane >> 2, t = lane & 3;
  float* dEw = reinterpret_cast<float*>(smem + p.encodingGrads) + row0 * p.ldDE; // fused mode only
  for (int n0 = 0; n0 < s.paddedInputs; n0 += 64)
  {
    const int nt = min(8, (s.paddedInputs - n0) / 8);
    float E[8][4];
#pragma unroll
    for (int j = 0; j < 8; ++j)
      E[j][0] = E[j][1] = E[j][2] = E[j][3] = 0.0f;
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
      mmaChunkT<8>(E, dA[kc], sh + p.weights[0], p.ldX0, kc * 16, n0, nt, lane);
#pragma unroll
    for (int j = 0; j < 8; ++j)
    {
      const int c = n0 + 8 * j + 2 * t;
      if (j >= nt || c >= s.inputs)
        continue;
#pragma unroll
      for (int k = 0; k < 2; ++k)
      {
        const float e0 = E[j][2 * k], e1 = E[j][2 * k + 1];
        if constexpr (Pre)
        {
          const int64_t gi = base + g + 8 * k;
          if (gi >= a.sampleCount)
            continue;
          if constexpr (F == 1)
          {
            a.dEncG[c * a.sampleCount + gi] = e0;
            if (c + 1 < s.inputs)
              a.dEncG[(c + 1) * a.sampleCount + gi] = e1;
          }
          else
          {
            const int l = c / F, f = c % F;
            *reinterpret_cast<float2*>(a.dEncG + (l * a.sampleCount + gi) * F + f) = make_float2(e0, e1);
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
    __syncwarp();
    scatterEncodingGradient<F>(a, dEw, base, lane);
  }
}

} // namespace gpu
} // namespace nv
