// NeuralVolume engine: the network evaluated one sample at a time with the numerics of the GPU In-Shader path.
//
// The GPU evaluates the encoding + MLP inside the ray-marching kernel on fp16 tensor-core operands: table entries
// in fp16, each level's interpolated features rounded to fp16, hidden weights in fp16, fp32 accumulation, every
// hidden activation rounded to fp16 after the ReLU, the output row in fp32 (fp32 weights) over the rounded last
// activations. This class computes exactly those roundings on the CPU (only the summation order differs), so the CPU
// In-Shader image is an oracle for the GPU one and a different computation from the fp32 batched inference of
// Sample Streaming.
#pragma once

#include "Core/HashGridMath.h"

#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__F16C__)
#include <immintrin.h>
#endif

namespace nv
{

class Model;

/// Nearest fp16 value of x (round to nearest even; overflow to infinity; NaN stays NaN), as a float. Portable.
inline float roundHalfPortable(float x)
{
  uint32_t u;
  std::memcpy(&u, &x, 4);
  const uint32_t sign = u & 0x80000000u, a = u & 0x7FFFFFFFu;
  uint32_t r;
  if (a >= 0x7F800000u)
    return x;
  if (a >= 0x477FF000u) // rounds to >= 65520: infinity
    r = 0x7F800000u;
  else if (a >= 0x38800000u) // normal fp16: keep 10 mantissa bits, ties to even
    r = (a + 0x0FFFu + ((a >> 13) & 1u)) & ~0x1FFFu;
  else // subnormal fp16: a multiple of 2^-24; in [0.5, 1) the float spacing is 2^-24, so the sum rounds for us
  {
    float m;
    std::memcpy(&m, &a, 4);
    m = (m + 0.5f) - 0.5f;
    std::memcpy(&r, &m, 4);
  }
  r |= sign;
  float y;
  std::memcpy(&y, &r, 4);
  return y;
}

/// Same as roundHalfPortable, with the F16C conversion instructions where the build has them.
inline float roundHalf(float x)
{
#if defined(__F16C__)
  return _cvtsh_ss(_cvtss_sh(x, _MM_FROUND_TO_NEAREST_INT));
#else
  return roundHalfPortable(x);
#endif
}

/// In place: every value of x[0..n) rounded to fp16 (8 at a time with F16C).
inline void roundHalfArray(float* x, int n)
{
  int i = 0;
#if defined(__F16C__)
  for (; i + 8 <= n; i += 8)
    _mm256_storeu_ps(x + i, _mm256_cvtph_ps(_mm256_cvtps_ph(_mm256_loadu_ps(x + i), _MM_FROUND_TO_NEAREST_INT)));
#endif
  for (; i < n; ++i)
    x[i] = roundHalf(x[i]);
}

/// The hash table rounded to fp16 (what the GPU gathers), made once per network version: a rounded copy, or none
/// when every entry is already an fp16 value (models stored in fp16).
class CpuHalfTable
{
public:
  /// The table of `model` (which must outlive the use of table()).
  void update(const Model& model, uint64_t version);
  const float* table() const { return Table; }

private:
  std::vector<float> Rounded;
  const float* Table = nullptr;
  const void* Source = nullptr;
  uint64_t Version = ~0ull;
};

class CpuHalfNetwork
{
public:
  /// `table16`: the model's hash table rounded to fp16 (CpuHalfTable), read in place; the MLP weights are copied.
  CpuHalfNetwork(const Model& model, const float* table16);

  /// Network outputs (normalised units) of n points xyz (interleaved, in [0,1]^3).
  void evaluate(const float* xyz, int n, float* out) const;

private:
  template <int W, int F>
  static void evaluateT(const CpuHalfNetwork& net, const float* xyz, int n, float* out);

  GridLayout Layout{};
  const float* Table = nullptr;
  int Inputs = 0, Width = 0, Hidden = 0;
  std::vector<float> Hidden16; ///< hidden layers transposed ([in][out]), rounded to fp16
  std::vector<float> Output;   ///< output row, fp32
  void (*Kernel)(const CpuHalfNetwork&, const float*, int, float*) = nullptr;
};

} // namespace nv
