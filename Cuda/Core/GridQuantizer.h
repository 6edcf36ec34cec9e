// NeuralVolume engine: 8-bit quantisation of hash-table entries with one step per level (Precision::Quantized8).
//
// An entry w of a level with step s > 0 is stored as the code k = clamp(round(w / s), -127, 127) and decodes to
// float(k) * s (in float arithmetic, the same on every host); a level of step 0 holds zeros. NaN codes as 0 and
// +-Inf as +-127. The step of a level is chosen to minimise the squared quantisation error (clipping included):
// the best of clipping levels max|w| x {1, 0.95, ..., 0.3}, then refined by least squares for its codes.
// Codes are entropy coded as symbols 0..254 (zigzag: 0, -1, 1, -2, 2, ...).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace nv
{

class GridQuantizer
{
public:
  static constexpr int kMaxCode = 127;
  static constexpr int kMaxSymbol = 2 * kMaxCode; ///< symbol of code -127

  /// Whether a step can be stored: 0, or a normal positive float whose 127 multiple is finite.
  static bool validStep(float step);

  /// The step of `n` values (finite ones count; a level of negligible values, below 127 x FLT_MIN, gets 0). At most
  /// 65536 of the values, evenly strided, are tried for each clipping level; the result is always validStep().
  static float chooseStep(const float* w, size_t n);

  /// Whether every value is exactly the decoded value of its code with `step` (then quantising changes nothing).
  static bool onGrid(const float* w, size_t n, float step);

  /// The code of w with a validStep() `step`: w / step rounded half away from zero (in double: exact for these
  /// magnitudes), clamped.
  static int code(float w, float step)
  {
    if (step == 0.0f || std::isnan(w))
      return 0;
    const double q = double(w) / double(step);
    return q >= double(kMaxCode) ? kMaxCode
      : q <= -double(kMaxCode)   ? -kMaxCode
                                 : static_cast<int>(q + (q >= 0.0 ? 0.5 : -0.5));
  }
  static float value(int code, float step) { return static_cast<float>(code) * step; }

  static uint8_t symbol(int code) { return static_cast<uint8_t>(code >= 0 ? 2 * code : -2 * code - 1); }
  /// The code of a symbol 0..kMaxSymbol.
  static int codeOf(uint8_t symbol) { return (symbol & 1u) ? -static_cast<int>((symbol + 1u) >> 1) : symbol >> 1; }

  /// Squared error of quantising the values with `step` (every `stride`-th value).
  static double squaredError(const float* w, size_t n, float step, size_t stride = 1);
};

} // namespace nv
