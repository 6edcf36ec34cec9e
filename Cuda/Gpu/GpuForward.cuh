// NeuralVolume engine: register-resident forward pass for inference and decoding (fast path).
//
// Each warp owns 16-sample tiles (persistent grid-stride loop over tiles; no block-wide barrier after the weights
// are staged): it encodes its 16 samples into a small per-warp shared buffer (fp16, 16 gathers in flight per
// lane), then runs the MLP with raw mma.sync m16n8k16 (fp16 operands, fp32 accumulation). The C fragment of layer
// k becomes the A fragment of layer k+1 after ReLU and fp16 packing, so hidden activations never leave registers.
// Weights (padded fp16, ld K+8) live in shared memory, loaded once per block; B fragments via ldmatrix.
// Arithmetic matches the WMMA path: fp32 accumulation, ReLU, fp16 rounding of each hidden activation, output row
// in fp32 over the fp16-rounded last activation. With Pre = true the encodings come from the level-major pass
// (GpuLevels.cuh, point arrays) instead of being gathered here (grid decoding).
#pragma once

#include "GpuLevels.cuh"

namespace nv
{
namespace gpu
{

/// Shared-memory layout of the fast forward kernel for blocks of `warps` warps; returns its size in bytes.
inline int fwdLayout(const MlpShape& s, int warps, FwdArgs& a)
{
  size_t wh = 0;
  for (int l = 0; l < s.H; ++l)
  {
    a.wOff[l] = static_cast<int>(wh);
    wh += static_cast<size_t>(s.W) * (s.inDim(l) + 8);
  }
  size_t o = roundUp128(wh * 2);
  a.woutOff = static_cast<int>(o);
  o += roundUp128(s.W * 4);
  a.encOff = static_cast<int>(o);
  a.ldE = s.Dp + 8;
  o += static_cast<size_t>(warps) * 16 * a.ldE * 2;
  return static_cast<int>(o);
}

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

__device__ __forceinline__ void mma16816(float (&c)[4], const uint32_t (&a)[4], uint32_t b0, uint32_t b1)
{
  asm("mma.sync.aligned.m16n8k16.row.col.f32.f16.f16.f32 {%0,%1,%2,%3}, {%4,%5,%6,%7}, {%8,%9}, "
      "{%0,%1,%2,%3};\n"
      : "+f"(c[0]), "+f"(c[1]), "+f"(c[2]), "+f"(c[3])
      : "r"(a[0]), "r"(a[1]), "r"(a[2]), "r"(a[3]), "r"(b0), "r"(b1));
}

__device__ __forceinline__ uint32_t packRelu(float x, float y)
{
  const __half2 h = __floats2half2_rn(fmaxf(x, 0.0f), fmaxf(y, 0.0f));
  return *reinterpret_cast<const uint32_t*>(&h);
}

/// A fragment kc of the next layer from the C fragments of this one: ReLU, fp16 (n-tiles 2kc, 2kc + 1).
template <int NT>
__device__ __forceinline__ void reluFragment(const float (&C)[NT][4], int kc, uint32_t (&A)[4])
{
  A[0] = packRelu(C[2 * kc][0], C[2 * kc][1]);
  A[1] = packRelu(C[2 * kc][2], C[2 * kc][3]);
  A[2] = packRelu(C[2 * kc + 1][0], C[2 * kc + 1][1]);
  A[3] = packRelu(C[2 * kc + 1][2], C[2 * kc + 1][3]);
}

/// C += A(16 x 16) . Wl[:, k0:k0+16]^T for all W outputs (W/8 n-tiles); Wl row-major [W][ldw] in shared memory.
template <int W>
__device__ __forceinline__ void mmaChunk(float (&C)[W / 8][4], const uint32_t (&A)[4], const __half* Wl, int ldw,
  int k0, int lane)
{
  const __half* p = Wl + ((lane & 7) + ((lane >> 4) << 3)) * ldw + k0 + ((lane >> 3) & 1) * 8;
#pragma unroll
  for (int j = 0; j < W / 8; j += 2)
  {
    uint32_t b[4];
    ldsm4(b, p + j * 8 * ldw);
    mma16816(C[j], A, b[0], b[1]);
    mma16816(C[j + 1], A, b[2], b[3]);
  }
}

/// Encode the warp's 16 samples (this lane: sample lane & 15 at x) into enc (16 x ldE halves). Lane half h
/// takes levels h, h+2, ...; two levels per iteration (16 gathers in flight).
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

template <int W, int F, int Warps, int MinBlocks, bool Pre>
__global__ void __launch_bounds__(Warps * 32, MinBlocks) forwardKernel(const __grid_constant__ FwdArgs a)
{
  extern __shared__ __align__(128) unsigned char smem[];
  const MlpShape& s = a.shape;
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  __half* sw = reinterpret_cast<__half*>(smem);
  float* swout = reinterpret_cast<float*>(smem + a.woutOff);
  __half* enc = reinterpret_cast<__half*>(smem + a.encOff) + warp * 16 * a.ldE;
  // Weights: layer l is W x K in global (K multiple of 16), W x (K + 8) here.
  for (int l = 0; l < s.H; ++l)
  {
    const int K = s.inDim(l), kv = K / 8;
    const uint4* src = reinterpret_cast<const uint4*>(a.w16 + s.off[l]);
    __half* dst = sw + a.wOff[l];
    for (int i = threadIdx.x; i < s.W * kv; i += blockDim.x)
      *reinterpret_cast<uint4*>(dst + (i / kv) * (K + 8) + (i % kv) * 8) = src[i];
  }
  for (int i = threadIdx.x; i < s.W; i += blockDim.x)
    swout[i] = a.wout[i];
  for (int i = lane; i < 16 * a.ldE; i += 32)
    enc[i] = __float2half(0.0f); // padding columns D..Dp-1 stay zero
  __syncthreads();

  const int r = lane & 15, g = lane >> 2, t = lane & 3;
  const int nk0 = s.Dp / 16;
  for (int64_t tile = int64_t(blockIdx.x) * Warps + warp; tile * 16 < a.n; tile += int64_t(gridDim.x) * Warps)
  {
    const int64_t o0 = tile * 16 + g, o1 = o0 + 8;
    // Where this lane's two outputs go: binned points carry their original index (loaded here, used at the end).
    int64_t d0 = o0, d1 = o1;
    if (a.binned && t == 0)
    {
      if (o0 < a.n)
        d0 = __float_as_uint(a.binned[o0].w);
      if (o1 < a.n)
        d1 = __float_as_uint(a.binned[o1].w);
    }
    __syncwarp(); // the previous tile's ldmatrix reads of enc are done
    if constexpr (Pre)
    {
      using V = typename HalfVec<F>::T;
      const V* src = reinterpret_cast<const V*>(a.enc);
      for (int it = lane; it < 16 * a.grid.levels; it += 32)
      {
        const int rr = it & 15, l = it >> 4;
        const int64_t gi = tile * 16 + rr;
        V v{};
        if (gi < a.n)
          v = __ldcs(src + l * a.n + gi); // streamed: read once
        *reinterpret_cast<V*>(enc + rr * a.ldE + l * F) = v;
      }
    }
    else
    {
      float x[3];
      fwdPoint(a, tile * 16 + r, x);
      encodeWarp<F>(a.grid, a.table16, x, enc, a.ldE, lane);
    }
    __syncwarp();

    float C[W / 8][4];
#pragma unroll
    for (int j = 0; j < W / 8; ++j)
      C[j][0] = C[j][1] = C[j][2] = C[j][3] = 0.0f;
    {
      const __half* ap = enc + (lane & 15) * a.ldE + (lane >> 4) * 8;
      const int ldw = s.Dp + 8;
      for (int kc = 0; kc < nk0; ++kc)
      {
        uint32_t A[4];
        ldsm4(A, ap + kc * 16);
        mmaChunk<W>(C, A, sw + a.wOff[0], ldw, kc * 16, lane);
      }
    }
    for (int l = 1; l < s.H; ++l)
    {
      uint32_t A[W / 16][4];
#pragma unroll
      for (int kc = 0; kc < W / 16; ++kc)
        reluFragment(C, kc, A[kc]);
#pragma unroll
      for (int j = 0; j < W / 8; ++j)
        C[j][0] = C[j][1] = C[j][2] = C[j][3] = 0.0f;
#pragma unroll
      for (int kc = 0; kc < W / 16; ++kc)
        mmaChunk<W>(C, A[kc], sw + a.wOff[l], W + 8, kc * 16, lane);
    }
    // Output row: fp32 over the fp16-rounded ReLU activations; this lane holds rows g, g+8, columns 8j+2t(+1).
    float lo = 0.0f, hi = 0.0f;
#pragma unroll
    for (int j = 0; j < W / 8; ++j)
    {
      const float w0 = swout[8 * j + 2 * t], w1 = swout[8 * j + 2 * t + 1];
      lo += __half2float(__float2half_rn(fmaxf(C[j][0], 0.0f))) * w0;
      lo += __half2float(__float2half_rn(fmaxf(C[j][1], 0.0f))) * w1;
      hi += __half2float(__float2half_rn(fmaxf(C[j][2], 0.0f))) * w0;
      hi += __half2float(__float2half_rn(fmaxf(C[j][3], 0.0f))) * w1;
    }
    lo += __shfl_xor_sync(0xffffffffu, lo, 1);
    hi += __shfl_xor_sync(0xffffffffu, hi, 1);
    lo += __shfl_xor_sync(0xffffffffu, lo, 2);
    hi += __shfl_xor_sync(0xffffffffu, hi, 2);
    if (t == 0)
    {
      if (o0 < a.n)
        a.out[d0] = lo;
      if (o1 < a.n)
        a.out[d1] = hi;
    }
  }
}

} // namespace gpu
} // namespace nv
