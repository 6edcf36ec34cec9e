// NeuralVolume engine: the map between a field's values and the network's normalised values, safe for every finite
// range, including one wider than the largest double (a float64 field from -1.5e308 to +1.5e308: hi - lo = inf).
#pragma once

#include "HostDevice.h"

#include <cfloat>

namespace nv
{
/// Source value v in [lo, hi] <-> normalised y in [0, 1]: y = (v - lo) / (hi - lo), v = lo + y * (hi - lo).
///
/// For a range whose width hi - lo is a finite double, every function is the plain formula, bit for bit. When the
/// width overflows (both ends finite), the map works on halves instead: v/2 - lo/2 and hi/2 - lo/2 are exact halvings
/// and finite, and the ratio is the same. De-normalised values saturate at +-DBL_MAX (never inf); widths and errors
/// in source units may be larger than DBL_MAX only where they are (width() is then inf).
/// A constant field (hi <= lo) normalises to 0 and de-normalises to lo.
class ValueRange
{
public:
  NV_HD ValueRange(double lo, double hi)
    : Lo(lo)
    , Hi(hi)
  {
    const double w = hi - lo;
    Halved = !(w <= DBL_MAX) && lo <= DBL_MAX && lo >= -DBL_MAX && hi <= DBL_MAX && hi >= -DBL_MAX;
    Width = Halved ? 0.5 * hi - 0.5 * lo : w;
    Inv = Width > 0.0 && !Halved ? 1.0 / Width : 0.0;
  }

  NV_HD double lo() const { return Lo; }
  NV_HD double hi() const { return Hi; }
  /// True when hi - lo overflows a double and the map works on halves.
  NV_HD bool halved() const { return Halved; }
  /// hi - lo (inf when it overflows).
  NV_HD double width() const { return Halved ? 2.0 * Width : Width; }
  /// A non-empty range (hi > lo).
  NV_HD bool spans() const { return Width > 0.0; }

  /// (v - lo) * (1 / (hi - lo)): the normalisation of training targets and reference grids; 0 for a constant field.
  /// Halved, it divides (1 / width would be subnormal and lose bits).
  NV_HD double normalize(double v) const { return Halved ? (0.5 * v - 0.5 * Lo) / Width : (v - Lo) * Inv; }
  /// (v - lo) / (hi - lo), by a division; 0 for a constant field.
  NV_HD double fraction(double v) const
  {
    return !(Width > 0.0) ? 0.0 : Halved ? (0.5 * v - 0.5 * Lo) / Width : (v - Lo) / Width;
  }
  /// lo + y * (hi - lo); lo for a constant field. A value beyond the largest double (y outside [0, 1] near the ends
  /// of the doubles) saturates at +-DBL_MAX; NaN stays NaN.
  NV_HD double denormalize(double y) const
  {
    const double v = Halved ? 2.0 * (0.5 * Lo + y * Width) : Lo + y * Width;
    return v > DBL_MAX ? DBL_MAX : v < -DBL_MAX ? -DBL_MAX : v;
  }
  /// t * (hi - lo): a normalised difference in source units (inf only where the product exceeds DBL_MAX).
  NV_HD double span(double t) const { return Halved ? 2.0 * (t * Width) : t * Width; }
  /// t / (hi - lo): a source-unit difference in normalised units (0 for a constant field).
  NV_HD double perWidth(double t) const { return !(Width > 0.0) ? 0.0 : Halved ? (0.5 * t) / Width : t / Width; }

private:
  double Lo;
  double Hi;
  double Width; ///< hi - lo, or (hi - lo) / 2 when halved
  double Inv;   ///< 1 / Width (not halved), 0 for a constant field
  bool Halved;
};

/// A de-normalised value stored in a decoded output of type T (float or double): a float saturates at +-FLT_MAX, so
/// a network that overshoots a float32 field reaching FLT_MAX never decodes to inf (a double needs nothing:
/// denormalize saturates at +-DBL_MAX). NaN stays NaN.
template <typename T>
NV_HD T storedValue(double v);
template <>
NV_HD float storedValue<float>(double v)
{
  return v > double(FLT_MAX) ? FLT_MAX : v < -double(FLT_MAX) ? -FLT_MAX : static_cast<float>(v);
}
template <>
NV_HD double storedValue<double>(double v)
{
  return v;
}

} // namespace nv
