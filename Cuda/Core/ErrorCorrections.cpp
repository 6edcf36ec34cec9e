#include "ErrorCorrections.h"

#include "Error.h"
#include "ValueRange.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace nv
{
namespace
{
int varintBytes(uint64_t v)
{
  int n = 1;
  while (v >= 0x80u)
  {
    v >>= 7;
    ++n;
  }
  return n;
}

void putVarint(std::vector<uint8_t>& out, uint64_t v)
{
  while (v >= 0x80u)
  {
    out.push_back(static_cast<uint8_t>(v | 0x80u));
    v >>= 7;
  }
  out.push_back(static_cast<uint8_t>(v));
}

uint64_t zigzag(int32_t v)
{
  return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31);
}

/// Reads one varint of at most 64 bits at `at` (advanced); throws when it runs past `bytes`.
uint64_t getVarint(const uint8_t* data, size_t bytes, size_t& at, const char* what)
{
  uint64_t v = 0;
  for (int shift = 0; shift < 64; shift += 7)
  {
    if (at >= bytes)
      NV_THROW(std::string("error corrections: the ") + what + " of a correction runs past the " +
        std::to_string(bytes) + " bytes of the list");
    const uint8_t b = data[at++];
    v |= static_cast<uint64_t>(b & 0x7Fu) << shift;
    if (!(b & 0x80u))
      return v;
  }
  NV_THROW(std::string("error corrections: a varint ") + what + " longer than 64 bits");
}

/// Walks a coded list, checking it; `visit(index, steps)` sees every correction.
template <typename Visit>
void walk(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples, Visit&& visit)
{
  NV_CHECK(data != nullptr || bytes == 0, "error corrections: null data");
  if (count > uint64_t(samples))
    NV_THROW("error corrections: " + std::to_string(count) + " corrections on a grid of " + std::to_string(samples) +
      " samples");
  size_t at = 0;
  int64_t previous = -1;
  for (uint64_t k = 0; k < count; ++k)
  {
    const uint64_t delta = getVarint(data, bytes, at, "index step");
    if (delta < 1 || delta > uint64_t(samples - 1 - previous))
      NV_THROW("error corrections: correction " + std::to_string(k) + " steps " + std::to_string(delta) +
        " samples from " + std::to_string(previous) + " on a grid of " + std::to_string(samples));
    previous += static_cast<int64_t>(delta);
    const uint64_t z = getVarint(data, bytes, at, "value");
    if (z == 0 || z > 0xFFFFFFFFull)
      NV_THROW("error corrections: correction " + std::to_string(k) + " of " + std::to_string(z) +
        " (zig-zag) steps: it must be non-zero and within 32 bits");
    const uint32_t z32 = static_cast<uint32_t>(z);
    const int32_t steps = static_cast<int32_t>((z32 >> 1) ^ (0u - (z32 & 1u)));
    visit(previous, steps);
  }
  if (at != bytes)
    NV_THROW("error corrections: the list takes " + std::to_string(at) + " of its " + std::to_string(bytes) +
      " bytes");
}

template <typename T>
void applyTo(const ErrorCorrections& c, int64_t first, int64_t count, T* values, double scale, double offset)
{
  if (!c.enabled() || c.index.empty() || count <= 0)
    return;
  const auto begin = std::lower_bound(c.index.begin(), c.index.end(), first);
  for (auto it = begin; it != c.index.end() && *it < first + count; ++it)
  {
    const size_t k = static_cast<size_t>(it - c.index.begin());
    T& v = values[*it - first];
    v = storedValue<T>(static_cast<double>(v) + (static_cast<double>(c.steps[k]) * c.bound) * scale + offset);
  }
}
} // namespace

int64_t ErrorCorrections::codedBytes() const
{
  int64_t bytes = 0, previous = -1;
  for (size_t k = 0; k < index.size(); ++k)
  {
    bytes += varintBytes(static_cast<uint64_t>(index[k] - previous)) + varintBytes(zigzag(steps[k]));
    previous = index[k];
  }
  return bytes;
}

int64_t ErrorCorrections::storedBytes() const
{
  return enabled() ? 8 + 8 + 8 + codedBytes() : 0; // bound, count, coded size, list
}

void validateErrorBound(double bound)
{
  NV_CHECK(std::isfinite(bound) && bound >= 0.0,
    "the error bound (MaxError) must be a finite number >= 0 in data units (0: off), got " + std::to_string(bound));
}

ErrorCorrections computeCorrections(const double* decoded, const VolumeView& source, double bound)
{
  ErrorCorrections c;
  c.bound = bound;
  appendCorrections(c, decoded, source, 0, source.count());
  return c;
}

void appendCorrections(ErrorCorrections& c, const double* decoded, const VolumeView& source, int64_t first,
  int64_t count)
{
  const double bound = c.bound;
  validateErrorBound(bound);
  NV_CHECK(bound > 0.0, "computeCorrections: an error bound > 0");
  NV_CHECK(decoded != nullptr && source.data != nullptr, "computeCorrections: null field");
  NV_CHECK(first >= 0 && count >= 0 && count <= source.count() - first, "computeCorrections: samples outside the grid");
  NV_CHECK(c.index.empty() || c.index.back() < first, "computeCorrections: slabs in ascending order");
  int64_t nonFinite = 0;
  for (int64_t i = first; i < first + count; ++i)
  {
    const double s = source.at(i);
    if (!std::isfinite(s))
      continue;
    const double d = decoded[i - first];
    if (!std::isfinite(d))
    {
      ++nonFinite;
      continue;
    }
    const double error = s - d;
    if (!(std::fabs(error) > kCorrectAbove * bound))
      continue;
    const double steps = std::nearbyint(error / bound);
    if (!(std::fabs(steps) <= 2147483647.0))
      NV_THROW("error bound " + std::to_string(bound) + " is too small for the network's error " +
        std::to_string(std::fabs(error)) + " at sample " + std::to_string(i) +
        " (a correction of more than 2^31 - 1 bounds); choose a larger MaxError");
    c.index.push_back(i);
    c.steps.push_back(static_cast<int32_t>(steps)); // |error| > 0.9 bound: steps is +-1 or more
  }
  if (nonFinite > 0)
    NV_THROW("the network's decoded value is not finite at " + std::to_string(nonFinite) +
      " samples (a diverged network): no error bound can be kept");
}

void applyCorrections(const ErrorCorrections& c, int64_t first, int64_t count, float* values)
{
  applyTo(c, first, count, values, 1.0, 0.0);
}

void applyCorrections(const ErrorCorrections& c, int64_t first, int64_t count, double* values)
{
  applyTo(c, first, count, values, 1.0, 0.0);
}

void applyCorrectionsNormalised(
  const ErrorCorrections& c, int64_t first, int64_t count, double valueMin, double valueMax, float* values)
{
  const ValueRange range(valueMin, valueMax);
  if (!range.spans())
    return; // a constant field decodes to its value exactly
  applyTo(c, first, count, values, 1.0 / (valueMax - valueMin), 0.0);
}

std::vector<uint8_t> encodeCorrections(const ErrorCorrections& c)
{
  NV_CHECK(c.index.size() == c.steps.size(), "error corrections: one step per index");
  std::vector<uint8_t> out;
  out.reserve(static_cast<size_t>(c.codedBytes()));
  int64_t previous = -1;
  for (size_t k = 0; k < c.index.size(); ++k)
  {
    NV_CHECK(c.index[k] > previous && c.steps[k] != 0, "error corrections: ascending indices, non-zero steps");
    putVarint(out, static_cast<uint64_t>(c.index[k] - previous));
    putVarint(out, zigzag(c.steps[k]));
    previous = c.index[k];
  }
  return out;
}

void inspectCorrections(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples)
{
  walk(data, bytes, count, samples, [](int64_t, int32_t) {});
}

ErrorCorrections decodeCorrections(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples, double bound)
{
  inspectCorrections(data, bytes, count, samples);
  ErrorCorrections c;
  c.bound = bound;
  c.index.reserve(static_cast<size_t>(count));
  c.steps.reserve(static_cast<size_t>(count));
  walk(data, bytes, count, samples, [&](int64_t i, int32_t s) {
    c.index.push_back(i);
    c.steps.push_back(s);
  });
  return c;
}

} // namespace nv
