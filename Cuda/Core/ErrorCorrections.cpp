#include "ErrorCorrections.h"

#include "Error.h"
#include "RansCoder.h"
#include "ValueRange.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace nv
{
namespace
{
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

/// Walks the two varint streams of a list (index steps, zig-zag steps), checking them; `visit(index, steps)` sees
/// every correction.
template <typename Visit>
void walk(const std::vector<uint8_t>& indexBytes, const std::vector<uint8_t>& stepBytes, uint64_t count,
  int64_t samples, Visit&& visit)
{
  size_t at = 0, stepAt = 0;
  int64_t previous = -1;
  for (uint64_t k = 0; k < count; ++k)
  {
    const uint64_t delta = getVarint(indexBytes.data(), indexBytes.size(), at, "index step");
    if (delta < 1 || delta > uint64_t(samples - 1 - previous))
      NV_THROW("error corrections: correction " + std::to_string(k) + " steps " + std::to_string(delta) +
        " samples from " + std::to_string(previous) + " on a grid of " + std::to_string(samples));
    previous += static_cast<int64_t>(delta);
    const uint64_t z = getVarint(stepBytes.data(), stepBytes.size(), stepAt, "value");
    if (z == 0 || z > 0xFFFFFFFFull)
      NV_THROW("error corrections: correction " + std::to_string(k) + " of " + std::to_string(z) +
        " (zig-zag) steps: it must be non-zero and within 32 bits");
    const uint32_t z32 = static_cast<uint32_t>(z);
    const int32_t steps = static_cast<int32_t>((z32 >> 1) ^ (0u - (z32 & 1u)));
    visit(previous, steps);
  }
  if (at != indexBytes.size() || stepAt != stepBytes.size())
    NV_THROW("error corrections: the list takes " + std::to_string(at) + " + " + std::to_string(stepAt) + " of its " +
      std::to_string(indexBytes.size()) + " + " + std::to_string(stepBytes.size()) + " varint bytes");
}

/// One stream of a coded list at data[at..bytes): u64 symbol count, then its rANS block (none for 0 symbols).
std::vector<uint8_t> readStream(const uint8_t* data, size_t bytes, size_t& at, uint64_t maxSymbols, const char* what)
{
  if (bytes - at < 8)
    NV_THROW(std::string("error corrections: the ") + what + " stream's size runs past the list");
  uint64_t n = 0;
  std::memcpy(&n, data + at, 8);
  at += 8;
  if (n > maxSymbols)
    NV_THROW(std::string("error corrections: a ") + what + " stream of " + std::to_string(n) +
      " bytes (at most " + std::to_string(maxSymbols) + ")");
  std::vector<uint8_t> out;
  if (n == 0)
    return out;
  RansCoder::inspect(data + at, bytes - at, n); // the stream's length against the bytes present, before allocating
  out.reserve(static_cast<size_t>(n));
  at += RansCoder::decode(data + at, bytes - at, n, [&out](const uint8_t* sym, size_t m) {
    out.insert(out.end(), sym, sym + m);
  });
  return out;
}

void putStream(std::vector<uint8_t>& out, const std::vector<uint8_t>& symbols)
{
  const uint64_t n = symbols.size();
  for (int k = 0; k < 8; ++k)
    out.push_back(static_cast<uint8_t>(n >> (8 * k))); // little endian
  if (n > 0)
    RansCoder::encode(symbols.data(), symbols.size(), out);
}

/// Decodes and checks a coded list; `visit(index, steps)` sees every correction.
template <typename Visit>
void walkCoded(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples, Visit&& visit)
{
  NV_CHECK(data != nullptr || bytes == 0, "error corrections: null data");
  if (count > uint64_t(samples))
    NV_THROW("error corrections: " + std::to_string(count) + " corrections on a grid of " + std::to_string(samples) +
      " samples");
  size_t at = 0;
  const std::vector<uint8_t> indexBytes = readStream(data, bytes, at, 10 * count, "index");
  const std::vector<uint8_t> stepBytes = readStream(data, bytes, at, 5 * count, "value");
  if (at != bytes)
    NV_THROW("error corrections: the list takes " + std::to_string(at) + " of its " + std::to_string(bytes) +
      " bytes");
  walk(indexBytes, stepBytes, count, samples, visit);
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
  return static_cast<int64_t>(encodeCorrections(*this).size());
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
  std::vector<uint8_t> indexBytes, stepBytes;
  indexBytes.reserve(c.index.size());
  stepBytes.reserve(c.index.size());
  int64_t previous = -1;
  for (size_t k = 0; k < c.index.size(); ++k)
  {
    NV_CHECK(c.index[k] > previous && c.steps[k] != 0, "error corrections: ascending indices, non-zero steps");
    putVarint(indexBytes, static_cast<uint64_t>(c.index[k] - previous));
    putVarint(stepBytes, zigzag(c.steps[k]));
    previous = c.index[k];
  }
  return packCorrectionStreams(indexBytes, stepBytes);
}

std::vector<uint8_t> packCorrectionStreams(const std::vector<uint8_t>& indexVarints, const std::vector<uint8_t>& stepVarints)
{
  std::vector<uint8_t> out;
  putStream(out, indexVarints);
  putStream(out, stepVarints);
  return out;
}

void inspectCorrections(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples)
{
  walkCoded(data, bytes, count, samples, [](int64_t, int32_t) {});
}

ErrorCorrections decodeCorrections(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples, double bound)
{
  ErrorCorrections c;
  c.bound = bound;
  // A list decodes to at most RansCoder::kMaxSymbolsPerByte varint bytes a coded byte: a hostile count fails in the
  // walk before the vectors grow far past that.
  const uint64_t reserve = std::min<uint64_t>(count, uint64_t(bytes) * RansCoder::kMaxSymbolsPerByte);
  c.index.reserve(static_cast<size_t>(reserve));
  c.steps.reserve(static_cast<size_t>(reserve));
  walkCoded(data, bytes, count, samples, [&](int64_t i, int32_t s) {
    c.index.push_back(i);
    c.steps.push_back(s);
  });
  return c;
}

} // namespace nv
