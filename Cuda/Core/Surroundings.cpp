#include "Surroundings.h"

#include "Error.h"
#include "RenderSetup.h"
#include "ValueRange.h"

#include <algorithm>
#include <cmath>

namespace nv
{

bool usesSurroundings(const RenderRequest& q)
{
  return q.surroundings && (q.shading == ShadingMode::RayMarchShadows || q.shading == ShadingMode::PathTrace ||
    q.shading == ShadingMode::PathTraceNee);
}

void checkSurroundings(const RenderRequest& q, std::ostream& os)
{
  if (!q.surroundings)
    return;
  const SurroundingsGrid& g = *q.surroundings;
  int64_t samples = 1;
  bool dimsOk = true;
  for (int a = 0; a < 3; ++a)
  {
    if (!(g.dims[a] >= 2 && g.dims[a] <= 65536))
      dimsOk = false;
    else
      samples *= g.dims[a]; // at most 2^48: no overflow
  }
  if (!dimsOk)
    os << "the surroundings grid needs 2..65536 samples per axis (has " << g.dims[0] << " x " << g.dims[1] << " x "
       << g.dims[2] << "); ";
  else if (samples > kMaxSurroundingsSamples)
    os << "the surroundings grid has " << samples << " samples (at most " << kMaxSurroundingsSamples << "); ";
  else if (static_cast<int64_t>(g.values.size()) != samples)
    os << "the surroundings grid has " << g.values.size() << " values for " << samples << " samples; ";
  for (int a = 0; a < 3; ++a)
  {
    const double lo = g.box[2 * a], hi = g.box[2 * a + 1];
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi && std::isfinite(hi - lo)))
    {
      os << "the surroundings box must be finite and non-empty on every axis; ";
      break;
    }
  }
}

double surroundingsEdgeLength(const SurroundingsGrid& g, const double b[9])
{
  double edges = 0.0;
  for (int a = 0; a < 3; ++a)
    edges += std::sqrt(b[a] * b[a] + b[3 + a] * b[3 + a] + b[6 + a] * b[6 + a]) * (g.box[2 * a + 1] - g.box[2 * a]);
  return edges;
}

float tableMajorant(const float* table, int tfSize, float c0, float c1)
{
  const float last = static_cast<float>(tfSize - 1);
  auto clampEntry = [last](float c) { return c < 0.0f ? 0.0f : (c > last ? last : c); };
  if (!(c0 == c0) || !(c1 == c1))
    return 0.0f;
  float lo = clampEntry(std::min(c0, c1)), hi = clampEntry(std::max(c0, c1));
  auto at = [&](float c) {
    int i = std::min(static_cast<int>(c), tfSize - 2);
    const float f = c - static_cast<float>(i);
    return table[4 * i + 3] + f * (table[4 * i + 7] - table[4 * i + 3]);
  };
  // Linear between entries: the largest value is at an end or at an entry in between.
  float m = std::max(at(lo), at(hi));
  for (int i = static_cast<int>(std::ceil(lo)); i <= static_cast<int>(std::floor(hi)); ++i)
    m = std::max(m, table[4 * i + 3]);
  return m;
}

namespace
{
/// Values normalised to their finite range (NaN for NaN and infinite ones); `range` lo > hi when none is finite.
void normalizeToOwnRange(const std::vector<float>& in, std::vector<float>& out, double range[2])
{
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (float v : in)
    if (std::isfinite(v))
    {
      lo = std::min(lo, static_cast<double>(v));
      hi = std::max(hi, static_cast<double>(v));
    }
  range[0] = lo;
  range[1] = hi;
  out.resize(in.size());
  const ValueRange map(lo, hi);
  for (size_t i = 0; i < in.size(); ++i)
    out[i] = std::isfinite(in[i]) ? static_cast<float>(map.normalize(static_cast<double>(in[i]))) : NAN;
}
} // namespace

bool SurroundingsCache::prepare(const RenderRequest& q, const RenderSetup& setup, ray::Params& P)
{
  P.surround = nullptr;
  P.surroundMajorant = 0.0f;
  if (!usesSurroundings(q))
    return false;
  const SurroundingsGrid& g = *q.surroundings;
  bool changed = false;
  if (Grid != q.surroundings)
  {
    normalizeToOwnRange(g.values, Values, Range);
    Grid = q.surroundings;
    changed = true;
  }
  P.surround = Values.data();
  for (int a = 0; a < 3; ++a)
  {
    P.surroundDims[a] = g.dims[a];
    P.surroundBox[2 * a] = static_cast<float>(g.box[2 * a]);
    P.surroundBox[2 * a + 1] = static_cast<float>(g.box[2 * a + 1]);
    P.surroundScale[a] = static_cast<float>(static_cast<double>(g.dims[a] - 1) / (g.box[2 * a + 1] - g.box[2 * a]));
  }
  if (!(Range[0] <= Range[1]))
    return changed; // no value anywhere: nothing beyond the clip box casts a shadow
  transferMap(q.transfer, Range[0], Range[1], P.surroundTfScale, P.surroundTfShift);
  NV_CHECK(std::isfinite(P.surroundTfScale) && std::isfinite(P.surroundTfShift),
    "the transfer function's range is too small for the surroundings' value range");
  // The grid's values span normalised [0, 1]: entries shift .. scale + shift.
  P.surroundMajorant = tableMajorant(setup.table.data(), P.tfSize, P.surroundTfShift,
    P.surroundTfScale + P.surroundTfShift);
  return changed;
}

} // namespace nv
