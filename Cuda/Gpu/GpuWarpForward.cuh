// NeuralVolume engine: THE forward pass on the GPU -- hash-grid encoding + MLP of one warp's 16 samples. Every
// kernel that evaluates the network calls warpForward (inference and decoding, both training kernels, the In-Shader
// renderer); its variants are template options, never run-time switches read from the environment:
//   Src      where the encodings come from: EncodeFrom<T> (gather + trilinear interpolation from the fp16 or fp32
//            table at this lane's point) or PreEncoded (the level-major pass of two-pass inference/training wrote
//            them; copied in);
//   Weights  WeightsInShared (padded fp16 rows, ld K + 8, B fragments by ldmatrix) or WeightsInGlobal (rows of the
//            padded layout read through L1; for shapes whose weights do not fit shared memory);
//   HalfAcc  fp16 accumulators (the In-Shader renderer: half the registers for the C fragments) or fp32;
//   Stage    training keeps each hidden layer's input X_l (l >= 1) and the last activation X_H.
// Arithmetic: encodings rounded to fp16, mma.sync m16n8k16 (fp16 operands), ReLU, fp16 rounding of each hidden
// activation, output row in fp32 over the fp16 last activation. Lane layout: sample r = lane & 15 is this lane's for
// encoding; results of rows g = lane >> 2 and g + 8 end on the four lanes t = lane & 3 of quad g.
#pragma once

#include "GpuLevels.cuh"

namespace nv
{
namespace gpu
{

/// ldmatrix x4 (Trans: the transposed 8 x 8 tiles) from shared memory.
template <bool Trans = false>
__device__ __forceinline__ void ldsm4(uint32_t (&r)[4], const void* p)
{
  const uint32_t a = static_cast<uint32_t>(__cvta_generic_to_shared(p));
  if constexpr (Trans)
    asm volatile("ldmatrix.sync.aligned.m8n8.x4.trans.shared.b16 {%0,%1,%2,%3}, [%4];\n"
                 : "=r"(r[0]), "=r"(r[1]), "=r"(r[2]), "=r"(r[3])
                 : "r"(a)
                 : "memory");
  else
    asm volatile("ldmatrix.sync.aligned.m8n8.x4.shared.b16 {%0,%1,%2,%3}, [%4];\n"
                 : "=r"(r[0]), "=r"(r[1]), "=r"(r[2]), "=r"(r[3])
                 : "r"(a)
                 : "memory");
}

/// C += A . B, fp32 accumulators (c: rows g / g + 8, columns 2t, 2t + 1). Ampere and newer: one m16n8k16; Turing:
/// two m16n8k8 over k 0..7 (a[0], a[1], b0) and k 8..15 (a[2], a[3], b1), the same fragments split in half.
__device__ __forceinline__ void mma16816(float (&c)[4], const uint32_t (&a)[4], uint32_t b0, uint32_t b1)
{
#if !defined(__CUDA_ARCH__) || __CUDA_ARCH__ >= 800
  asm("mma.sync.aligned.m16n8k16.row.col.f32.f16.f16.f32 {%0,%1,%2,%3}, {%4,%5,%6,%7}, {%8,%9}, "
      "{%0,%1,%2,%3};\n"
      : "+f"(c[0]), "+f"(c[1]), "+f"(c[2]), "+f"(c[3])
      : "r"(a[0]), "r"(a[1]), "r"(a[2]), "r"(a[3]), "r"(b0), "r"(b1));
#else
  asm("mma.sync.aligned.m16n8k8.row.col.f32.f16.f16.f32 {%0,%1,%2,%3}, {%4,%5}, {%6}, {%0,%1,%2,%3};\n"
      : "+f"(c[0]), "+f"(c[1]), "+f"(c[2]), "+f"(c[3])
      : "r"(a[0]), "r"(a[1]), "r"(b0));
  asm("mma.sync.aligned.m16n8k8.row.col.f32.f16.f16.f32 {%0,%1,%2,%3}, {%4,%5}, {%6}, {%0,%1,%2,%3};\n"
      : "+f"(c[0]), "+f"(c[1]), "+f"(c[2]), "+f"(c[3])
      : "r"(a[2]), "r"(a[3]), "r"(b1));
#endif
}

/// C += A . B, fp16 accumulators (c[0]: row g, c[1]: row g + 8; columns 2t, 2t + 1 packed); split as above on Turing.
__device__ __forceinline__ void mma16816(uint32_t (&c)[2], const uint32_t (&a)[4], uint32_t b0, uint32_t b1)
{
#if !defined(__CUDA_ARCH__) || __CUDA_ARCH__ >= 800
  asm("mma.sync.aligned.m16n8k16.row.col.f16.f16.f16.f16 {%0,%1}, {%2,%3,%4,%5}, {%6,%7}, {%0,%1};\n"
      : "+r"(c[0]), "+r"(c[1])
      : "r"(a[0]), "r"(a[1]), "r"(a[2]), "r"(a[3]), "r"(b0), "r"(b1));
#else
  asm("mma.sync.aligned.m16n8k8.row.col.f16.f16.f16.f16 {%0,%1}, {%2,%3}, {%4}, {%0,%1};\n"
      : "+r"(c[0]), "+r"(c[1])
      : "r"(a[0]), "r"(a[1]), "r"(b0));
  asm("mma.sync.aligned.m16n8k8.row.col.f16.f16.f16.f16 {%0,%1}, {%2,%3}, {%4}, {%0,%1};\n"
      : "+r"(c[0]), "+r"(c[1])
      : "r"(a[2]), "r"(a[3]), "r"(b1));
#endif
}

__device__ __forceinline__ uint32_t packRelu(float x, float y)
{
  const __half2 h = __floats2half2_rn(fmaxf(x, 0.0f), fmaxf(y, 0.0f));
  return *reinterpret_cast<const uint32_t*>(&h);
}

__device__ __forceinline__ uint32_t reluHalf2(uint32_t v)
{
  const __half2 h = __hmax2(*reinterpret_cast<const __half2*>(&v), __float2half2_rn(0.0f));
  return *reinterpret_cast<const uint32_t*>(&h);
}

/// Accumulator fragment of one n-tile (8 columns) for fp32 or fp16 accumulation.
template <bool HalfAcc>
struct AccFrag
{
  float values[4];
  __device__ __forceinline__ void zero() { values[0] = values[1] = values[2] = values[3] = 0.0f; }
  /// ReLU'd fp16 pairs: row g, row g + 8.
  __device__ __forceinline__ uint32_t lo() const { return packRelu(values[0], values[1]); }
  __device__ __forceinline__ uint32_t hi() const { return packRelu(values[2], values[3]); }
  __device__ __forceinline__ void mma(const uint32_t (&a)[4], uint32_t b0, uint32_t b1) { mma16816(values, a, b0, b1); }
};
template <>
struct AccFrag<true>
{
  uint32_t values[2];
  __device__ __forceinline__ void zero() { values[0] = values[1] = 0u; }
  __device__ __forceinline__ uint32_t lo() const { return reluHalf2(values[0]); }
  __device__ __forceinline__ uint32_t hi() const { return reluHalf2(values[1]); }
  __device__ __forceinline__ void mma(const uint32_t (&a)[4], uint32_t b0, uint32_t b1) { mma16816(values, a, b0, b1); }
};

/// Layer weights as the forward pass reads them: padded fp16 rows [W][K], layer l at base + off[l] with leading
/// dimension ld0 (layer 0) or ldh (hidden layers), and the fp32 output row. `off` points at kernel-parameter or
/// shared memory, so indexing it by layer costs no local memory.
struct WarpNet
{
  const __half* base;
  const int* off;
  int ld0, ldh;
  const float* wout;
};

struct WeightsInShared
{
};
struct WeightsInGlobal
{
};

/// C += A(16 x 16) . Wl[:, k0:k0+16]^T for all W outputs (W/8 n-tiles); Wl row-major [W][ldw].
template <int W, bool HalfAcc, typename Weights>
__device__ __forceinline__ void mmaChunk(AccFrag<HalfAcc> (&C)[W / 8], const uint32_t (&A)[4], const __half* Wl,
  int ldw, int k0, int lane)
{
  if constexpr (std::is_same<Weights, WeightsInShared>::value)
  {
    const __half* p = Wl + ((lane & 7) + ((lane >> 4) << 3)) * ldw + k0 + ((lane >> 3) & 1) * 8;
#pragma unroll
    for (int j = 0; j < W / 8; j += 2)
    {
      uint32_t b[4];
      ldsm4(b, p + j * 8 * ldw);
      C[j].mma(A, b[0], b[1]);
      C[j + 1].mma(A, b[2], b[3]);
    }
  }
  else
  {
    // The B fragment of n-tile j: rows 8j + g, columns k0 + 2t (+1) and k0 + 2t + 8 (+1), as ldmatrix would give.
    const __half* p = Wl + (lane >> 2) * ldw + k0 + 2 * (lane & 3);
#pragma unroll
    for (int j = 0; j < W / 8; ++j)
    {
      const __half* q = p + j * 8 * ldw;
      C[j].mma(A, __ldg(reinterpret_cast<const unsigned int*>(q)), __ldg(reinterpret_cast<const unsigned int*>(q + 8)));
    }
  }
}

/// Encode the warp's 16 samples (this lane: sample lane & 15 at x) into enc (16 x ldE halves). Lane half h takes
/// levels h, h+2, ...; two levels per iteration (16 gathers in flight).
template <int F, typename T = __half>
__device__ __forceinline__ void encodeWarp(const GridLayout& g, const T* __restrict__ table, const float x[3],
  __half* enc, int ldE, int lane)
{
  using E = Entry<T, F>;
  using V = typename HalfVec<F>::T;
  const int r = lane & 15;
  for (int l0 = lane >> 4; l0 < g.levels; l0 += 4)
  {
    const int l1 = l0 + 2;
    const bool two = l1 < g.levels;
    uint32_t idx[2][8];
    float frac[2][3];
#pragma unroll
    for (int k = 0; k < 2; ++k)
    {
      const LevelInfo& lv = g.level[k == 0 ? l0 : (two ? l1 : l0)];
      uint32_t corner[3];
      gridPosition(lv, x, corner, frac[k]);
#pragma unroll
      for (int c = 0; c < 8; ++c)
        idx[k][c] = fastCornerIndex(lv, c, corner);
    }
    float acc[2][F];
    gatherTwo<F, E>(table, idx, frac, acc);
#pragma unroll
    for (int k = 0; k < 2; ++k)
    {
      if (k == 1 && !two)
        break;
      __align__(16) __half o[F];
#pragma unroll
      for (int f = 0; f < F; ++f)
        o[f] = __float2half_rn(acc[k][f]);
      *reinterpret_cast<V*>(enc + r * ldE + (k == 0 ? l0 : l1) * F) = *reinterpret_cast<const V*>(o);
    }
  }
}

/// Encoding source: gather from the table (fp16 copy or fp32 parameters) at this lane's point.
template <typename T>
struct EncodeFrom
{
  const T* table;
};
/// Encoding source: level-major encodings (level l of sample i at (l * sampleCount + i) * F), rows [row, row + 16).
/// Rows from `live` on (>= 0: a device-side count below the capacity sampleCount) read as zeros.
struct PreEncoded
{
  const __half* enc;
  int64_t row, sampleCount;
  int64_t live = -1;
};

/// Staging of the activations for a backward pass: X_l (l = 1..H-1) at base + off[l] (ld `ld`) and, when xh is not
/// null, the last activation X_H at xh (ld ldh). Rows are the warp's 16 (base and xh point at its first row).
struct StageActivations
{
  __half* base;
  const int* off;
  int ld;
  __half* xh;
  int ldh;
};
struct NoStage
{
};

/// Store an A fragment (16 x 16 block kc of a warp's 16 rows) into row-major fp16 staging (ld halves).
__device__ __forceinline__ void storeFrag(const uint32_t (&A)[4], __half* rows, int ld, int kc, int lane)
{
  const int g = lane >> 2, t = lane & 3;
  __half* p = rows + g * ld + kc * 16 + 2 * t;
  *reinterpret_cast<uint32_t*>(p) = A[0];
  *reinterpret_cast<uint32_t*>(p + 8 * ld) = A[1];
  *reinterpret_cast<uint32_t*>(p + 8) = A[2];
  *reinterpret_cast<uint32_t*>(p + 8 * ld + 8) = A[3];
}

/// Result of warpForward on every lane: outputs of rows g (lo) and g + 8 (hi), reduced over the quad, and (with
/// StageActivations) the last activation X_H as packed fp16 pairs (columns 8j + 2t, +1 of rows g / g + 8).
template <int W>
struct WarpOut
{
  float lo, hi;
  uint32_t xh[W / 8][2];
};

/// 1. Encodings of the warp's 16 samples into enc: copied from the level-major pass's output (PreEncoded) ...
template <int F>
__device__ __forceinline__ void warpEncodings(const GridLayout& grid, const PreEncoded& src, const float x[3],
  __half* enc, int ldE, int lane)
{
  using V = typename HalfVec<F>::T;
  const V* e = reinterpret_cast<const V*>(src.enc);
  for (int it = lane; it < 16 * grid.levels; it += 32)
  {
    const int rr = it & 15, l = it >> 4;
    const int64_t gi = src.row + rr;
    V v{};
    if (gi < (src.live >= 0 ? src.live : src.sampleCount))
      v = __ldcs(e + l * src.sampleCount + gi); // streamed: read once
    *reinterpret_cast<V*>(enc + rr * ldE + l * F) = v;
  }
}

/// ... or gathered from the table at this lane's point x (EncodeFrom).
template <int F, typename T>
__device__ __forceinline__ void warpEncodings(const GridLayout& grid, const EncodeFrom<T>& src, const float x[3],
  __half* enc, int ldE, int lane)
{
  encodeWarp<F>(grid, src.table, x, enc, ldE, lane);
}

/// 3. Output row in fp32 over the fp16 last activation X_H (rows g, g + 8; columns 8j + 2t, +1 on this lane),
/// reduced over the quad into out.lo / out.hi; with StageActivations, X_H into out.xh (and stage.xh when set).
template <int W, bool HalfAcc, typename Stage>
__device__ __forceinline__ void outputRowForward(const WarpNet& net, int lane, const Stage& stage,
  const AccFrag<HalfAcc> (&C)[W / 8], WarpOut<W>& out)
{
  const int t = lane & 3;
  float lo = 0.0f, hi = 0.0f;
  constexpr bool keep = std::is_same<Stage, StageActivations>::value;
#pragma unroll
  for (int j = 0; j < W / 8; ++j)
  {
    const uint32_t x0 = C[j].lo(), x1 = C[j].hi();
    if constexpr (keep)
    {
      out.xh[j][0] = x0;
      out.xh[j][1] = x1;
    }
    const __half2 h0 = *reinterpret_cast<const __half2*>(&x0);
    const __half2 h1 = *reinterpret_cast<const __half2*>(&x1);
    const float w0 = net.wout[8 * j + 2 * t], w1 = net.wout[8 * j + 2 * t + 1];
    lo += __low2float(h0) * w0 + __high2float(h0) * w1;
    hi += __low2float(h1) * w0 + __high2float(h1) * w1;
  }
  if constexpr (keep)
  {
    if (stage.xh)
    {
#pragma unroll
      for (int kc = 0; kc < W / 16; ++kc)
      {
        const uint32_t A[4] = { out.xh[2 * kc][0], out.xh[2 * kc][1], out.xh[2 * kc + 1][0], out.xh[2 * kc + 1][1] };
        storeFrag(A, stage.xh, stage.ldh, kc, lane);
      }
    }
  }
  lo += __shfl_xor_sync(0xffffffffu, lo, 1);
  hi += __shfl_xor_sync(0xffffffffu, hi, 1);
  lo += __shfl_xor_sync(0xffffffffu, lo, 2);
  hi += __shfl_xor_sync(0xffffffffu, hi, 2);
  out.lo = lo;
  out.hi = hi;
}

/// The forward pass of one warp's 16 samples. `x`: this lane's point (sample lane & 15; EncodeFrom only);
/// `enc`: the warp's 16 staging rows (ld ldE >= Dp + 8 halves; columns D..Dp-1 must hold zeros).
template <int W, int F, bool HalfAcc, typename Weights, typename Src, typename Stage>
__device__ __forceinline__ void warpForward(const GridLayout& grid, const MlpShape& s, const WarpNet& net,
  const Src& src, const float x[3], __half* enc, int ldE, int lane, const Stage& stage, WarpOut<W>& out)
{
  // 1. Encodings of the 16 samples.
  warpEncodings<F>(grid, src, x, enc, ldE, lane);
  __syncwarp();

  // 2. Hidden layers; the C fragments of layer l become the A fragments of layer l + 1 (ReLU, fp16). Inline here: as
  // a helper (C by reference) it changed the PTX order of the accumulators and so the kernels' register allocation.
  AccFrag<HalfAcc> C[W / 8];
#pragma unroll
  for (int j = 0; j < W / 8; ++j)
    C[j].zero();
  {
    const __half* ap = enc + (lane & 15) * ldE + (lane >> 4) * 8;
    for (int kc = 0; kc < s.paddedInputs / 16; ++kc)
    {
      uint32_t A[4];
      ldsm4(A, ap + kc * 16);
      mmaChunk<W, HalfAcc, Weights>(C, A, net.base + net.off[0], net.ld0, kc * 16, lane);
    }
  }
  for (int l = 1; l < s.hiddenLayers; ++l)
  {
    uint32_t A[W / 16][4];
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
    {
      A[kc][0] = C[2 * kc].lo();
      A[kc][1] = C[2 * kc].hi();
      A[kc][2] = C[2 * kc + 1].lo();
      A[kc][3] = C[2 * kc + 1].hi();
      if constexpr (std::is_same<Stage, StageActivations>::value)
        storeFrag(A[kc], stage.base + stage.off[l], stage.ld, kc, lane);
    }
#pragma unroll
    for (int j = 0; j < W / 8; ++j)
      C[j].zero();
#pragma unroll
    for (int kc = 0; kc < W / 16; ++kc)
      mmaChunk<W, HalfAcc, Weights>(C, A[kc], net.base + net.off[l], net.ldh, kc * 16, lane);
  }

  // 3. Output row.
  outputRowForward<W, HalfAcc>(net, lane, stage, C, out);
}

} // namespace gpu
} // namespace nv
