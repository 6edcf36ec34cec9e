// NeuralVolume engine: register-blocked small matrix products for the CPU MLP (header-only, internal).
//
// C (rows x cols) = A (rows x K) * B (K x cols), B row-major. A is read through strides (element (r, k) at
// a[r * ars + k * aks]), so one kernel serves X * W^T (forward, input gradients) and dZ^T * X (weight gradients).
// Every C element is summed over k in ascending order with fused multiply-adds, starting from 0 or from C itself:
// the result does not depend on the blocking, so it is the same for every vector width and thread count.
#pragma once

#include <cstddef>
#include <cstring>

namespace nv
{
namespace gemm
{

#if defined(__AVX512F__)
constexpr int kVW = 16; ///< floats per vector
constexpr int kNV = 4;  ///< vectors per column block
constexpr int kR = 6;   ///< rows per register block (kR * kNV accumulators out of 32 registers)
#elif defined(__AVX__)
constexpr int kVW = 8;
constexpr int kNV = 2;
constexpr int kR = 6; // 12 accumulators out of 16 registers
#else
constexpr int kVW = 4;
constexpr int kNV = 2;
constexpr int kR = 6;
#endif

typedef float Vec __attribute__((vector_size(kVW * sizeof(float))));

inline Vec load(const float* p)
{
  Vec v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

inline void store(float* p, Vec v)
{
  std::memcpy(p, &v, sizeof v);
}

inline Vec splat(float s)
{
  return Vec{} + s;
}

/// What a kernel does with the sum before it writes C.
enum class Epilogue
{
  Store,     ///< C = sum
  Relu,      ///< C = max(sum, 0)
  Accumulate,///< C = C + sum, summed from C's value on (C is the first term)
  Mask       ///< C = mask > 0 ? sum : 0 (mask laid out like C)
};

struct Operands
{
  const float* lhs;
  ptrdiff_t ars, aks; ///< A(r, k) = lhs[r * ars + k * aks]
  const float* rhs;
  ptrdiff_t ldb; ///< B(k, c) = rhs[k * ldb + c]
  float* result; ///< C
  ptrdiff_t ldc;
  const float* mask; ///< Epilogue::Mask only; same layout as C
  int innerDim; ///< the k range: C(r, c) = sum over k < innerDim of A(r, k) B(k, c)
};

/// One register block: R rows x NV vectors of columns starting at (r0, c0).
template <int R, int NV, Epilogue E>
inline void block(const Operands& o, int r0, int c0)
{
  Vec acc[R][NV];
  for (int r = 0; r < R; ++r)
  {
    for (int v = 0; v < NV; ++v)
    {
      acc[r][v] = E == Epilogue::Accumulate ? load(o.result + (r0 + r) * o.ldc + c0 + v * kVW) : Vec{};
    }
  }
  const float* a = o.lhs + r0 * o.ars;
  const float* b = o.rhs + c0;
  for (int k = 0; k < o.innerDim; ++k)
  {
    Vec bv[NV];
    for (int v = 0; v < NV; ++v)
    {
      bv[v] = load(b + k * o.ldb + v * kVW);
    }
    for (int r = 0; r < R; ++r)
    {
      const Vec av = splat(a[r * o.ars + k * o.aks]);
      for (int v = 0; v < NV; ++v)
      {
        acc[r][v] += av * bv[v];
      }
    }
  }
  for (int r = 0; r < R; ++r)
  {
    for (int v = 0; v < NV; ++v)
    {
      float* dst = o.result + (r0 + r) * o.ldc + c0 + v * kVW;
      Vec x = acc[r][v];
      if (E == Epilogue::Relu)
      {
        x = x > Vec{} ? x : Vec{};
      }
      else if (E == Epilogue::Mask)
      {
        const Vec m = load(o.mask + (r0 + r) * o.ldc + c0 + v * kVW);
        x = m > Vec{} ? x : Vec{};
      }
      store(dst, x);
    }
  }
}

/// Rows [r0, rows) in blocks of kR, then the remaining rows one block each.
template <int NV, Epilogue E>
inline void columnBlock(const Operands& o, int rows, int c0)
{
  int r = 0;
  for (; r + kR <= rows; r += kR)
  {
    block<kR, NV, E>(o, r, c0);
  }
  switch (rows - r)
  {
    case 5:
      return block<5, NV, E>(o, r, c0);
    case 4:
      return block<4, NV, E>(o, r, c0);
    case 3:
      return block<3, NV, E>(o, r, c0);
    case 2:
      return block<2, NV, E>(o, r, c0);
    case 1:
      return block<1, NV, E>(o, r, c0);
    default:
      return;
  }
}

/// Columns that do not fill a vector: plain loops, the same order of summation.
template <Epilogue E>
inline void scalarColumns(const Operands& o, int rows, int c0, int c1)
{
  for (int r = 0; r < rows; ++r)
  {
    for (int c = c0; c < c1; ++c)
    {
      float* dst = o.result + r * o.ldc + c;
      float acc = E == Epilogue::Accumulate ? *dst : 0.0f;
      for (int k = 0; k < o.innerDim; ++k)
      {
        acc += o.lhs[r * o.ars + k * o.aks] * o.rhs[k * o.ldb + c];
      }
      if (E == Epilogue::Relu)
      {
        acc = acc > 0.0f ? acc : 0.0f;
      }
      else if (E == Epilogue::Mask)
      {
        acc = o.mask[r * o.ldc + c] > 0.0f ? acc : 0.0f;
      }
      *dst = acc;
    }
  }
}

template <Epilogue E>
inline void multiply(const Operands& o, int rows, int cols)
{
  int c = 0;
  for (; c + kNV * kVW <= cols; c += kNV * kVW)
  {
    columnBlock<kNV, E>(o, rows, c);
  }
  for (; c + kVW <= cols; c += kVW)
  {
    columnBlock<1, E>(o, rows, c);
  }
  if (c < cols)
  {
    scalarColumns<E>(o, rows, c, cols);
  }
}

} // namespace gemm
} // namespace nv
