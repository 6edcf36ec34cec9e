#include "RansCoder.h"

#include "Error.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace nv
{
namespace
{
constexpr uint32_t kStateLow = 1u << 23; ///< the state stays in [kStateLow, 256 * kStateLow) between symbols
constexpr size_t kChunk = 4096;

[[noreturn]] void corrupt(const std::string& what)
{
  throw Error("corrupt entropy-coded stream: " + what);
}

void putVarint(uint32_t v, std::vector<uint8_t>& out)
{
  while (v >= 0x80u)
  {
    out.push_back(static_cast<uint8_t>(v | 0x80u));
    v >>= 7;
  }
  out.push_back(static_cast<uint8_t>(v));
}

/// A parsed table: frequencies and cumulative starts of symbols 0..K-1.
struct Table
{
  uint32_t symbols = 0;
  uint32_t freq[256] = {};
  uint32_t start[256] = {};
  size_t bytes = 0; ///< bytes of the table and the stream length field
  uint32_t streamBytes = 0;
};

/// Reads and validates the table and the stream length of a block; allocates nothing.
Table readTable(const uint8_t* data, size_t size, uint64_t n)
{
  Table t;
  size_t pos = 0;
  if (size < 1)
    corrupt("the block ends before its symbol count");
  t.symbols = uint32_t(data[pos++]) + 1;
  uint64_t sum = 0;
  for (uint32_t s = 0; s < t.symbols; ++s)
  {
    uint32_t v = 0;
    for (int shift = 0;; shift += 7)
    {
      if (pos >= size)
        corrupt("the block ends inside its frequency table");
      if (shift > 14)
        corrupt("a frequency of more than 3 bytes");
      const uint8_t b = data[pos++];
      v |= uint32_t(b & 0x7Fu) << shift;
      if (!(b & 0x80u))
        break;
    }
    if (v > RansCoder::kScale)
      corrupt("frequency " + std::to_string(v) + " above the scale " + std::to_string(RansCoder::kScale));
    t.freq[s] = v;
    t.start[s] = static_cast<uint32_t>(sum);
    sum += v;
  }
  if (sum != RansCoder::kScale)
    corrupt("frequencies sum to " + std::to_string(sum) + ", not " + std::to_string(RansCoder::kScale));
  if (t.freq[t.symbols - 1] == 0)
    corrupt("the table's last symbol has frequency 0");
  if (size - pos < 4)
    corrupt("the block ends before its stream length");
  std::memcpy(&t.streamBytes, data + pos, 4);
  pos += 4;
  if (t.streamBytes < RansCoder::minStreamBytes(n))
    corrupt("a stream of " + std::to_string(t.streamBytes) + " bytes for " + std::to_string(n) + " symbols (at least " +
      std::to_string(RansCoder::minStreamBytes(n)) + ")");
  if (size - pos < t.streamBytes)
    corrupt("the stream of " + std::to_string(t.streamBytes) + " bytes is truncated (" + std::to_string(size - pos) +
      " present)");
  t.bytes = pos;
  return t;
}
} // namespace

void RansCoder::normalize(const uint64_t counts[256], uint64_t n, uint32_t freq[256])
{
  std::fill(freq, freq + 256, 0u);
  if (n == 0)
  {
    freq[0] = kScale;
    return;
  }
  int64_t sum = 0;
  for (int s = 0; s < 256; ++s)
  {
    if (counts[s] == 0)
      continue;
    const double share = double(counts[s]) * kScale / double(n);
    freq[s] = std::max<uint32_t>(1u, static_cast<uint32_t>(share));
    sum += freq[s];
  }
  // Hand out (or take back) the difference one slot at a time where it changes the coded size least: a slot more for
  // symbol s saves counts[s] * log2((f + 1) / f) bits, a slot less costs counts[s] * log2(f / (f - 1)).
  while (sum != int64_t(kScale))
  {
    int best = -1;
    double bestValue = 0.0;
    for (int s = 0; s < 256; ++s)
    {
      if (counts[s] == 0 || (sum > int64_t(kScale) && freq[s] <= 1))
        continue;
      const double f = freq[s];
      const double value = sum < int64_t(kScale) ? double(counts[s]) * std::log2((f + 1.0) / f)
                                                 : -double(counts[s]) * std::log2(f / (f - 1.0));
      if (best < 0 || value > bestValue)
      {
        best = s;
        bestValue = value;
      }
    }
    // At most 256 symbols of at least one slot each: a symbol with more than one slot exists while sum > kScale.
    if (sum < int64_t(kScale))
    {
      ++freq[best];
      ++sum;
    }
    else
    {
      --freq[best];
      --sum;
    }
  }
}

void RansCoder::encode(const uint8_t* symbols, size_t n, std::vector<uint8_t>& out)
{
  uint64_t counts[256] = {};
  for (size_t i = 0; i < n; ++i)
    ++counts[symbols[i]];
  uint32_t freq[256], start[256];
  normalize(counts, n, freq);
  uint32_t last = 0;
  uint32_t cumulative = 0;
  for (uint32_t s = 0; s < 256; ++s)
  {
    start[s] = cumulative;
    cumulative += freq[s];
    if (freq[s] > 0)
      last = s;
  }
  out.push_back(static_cast<uint8_t>(last));
  for (uint32_t s = 0; s <= last; ++s)
    putVarint(freq[s], out);

  // Symbols in reverse order; the bytes come out in reverse of the decoder's reading order. A symbol of frequency f
  // emits at most 2 + log2(kScale / f) bits: with every symbol of frequency 1, fewer than 2 bytes each.
  std::vector<uint8_t> reversed(2 * n + 8);
  uint8_t* o = reversed.data();
  uint32_t x = kStateLow;
  for (size_t i = n; i-- > 0;)
  {
    const uint32_t s = symbols[i];
    const uint32_t f = freq[s];
    const uint32_t limit = ((kStateLow >> kScaleBits) << 8) * f;
    while (x >= limit)
    {
      *o++ = static_cast<uint8_t>(x & 0xFFu);
      x >>= 8;
    }
    const uint32_t q = x / f;
    x = (q << kScaleBits) + (x - q * f) + start[s];
  }
  for (int k = 3; k >= 0; --k)
    *o++ = static_cast<uint8_t>(x >> (8 * k));
  reversed.resize(size_t(o - reversed.data()));
  const uint64_t padded = std::max<uint64_t>(reversed.size(), minStreamBytes(n));
  NV_CHECK(padded <= 0xFFFFFFFFu, "an entropy-coded stream of 4 GiB or more");
  const uint32_t streamBytes = static_cast<uint32_t>(padded);
  const uint8_t* p = reinterpret_cast<const uint8_t*>(&streamBytes); // little endian (checked by the format)
  out.insert(out.end(), p, p + 4);
  out.insert(out.end(), reversed.rbegin(), reversed.rend());
  out.resize(out.size() + (padded - reversed.size()), 0u);
}

size_t RansCoder::inspect(const uint8_t* data, size_t size, uint64_t n)
{
  const Table t = readTable(data, size, n);
  return t.bytes + t.streamBytes;
}

size_t RansCoder::decode(const uint8_t* data, size_t size, uint64_t n, const Sink& sink)
{
  const Table t = readTable(data, size, n);
  const uint8_t* stream = data + t.bytes;
  const size_t streamBytes = t.streamBytes; // >= 4 (minStreamBytes)
  // Slot -> symbol: only symbols with a frequency own slots.
  std::vector<uint8_t> slotSymbol(kScale);
  for (uint32_t s = 0; s < t.symbols; ++s)
    std::fill(slotSymbol.begin() + t.start[s], slotSymbol.begin() + t.start[s] + t.freq[s], static_cast<uint8_t>(s));
  uint32_t x;
  std::memcpy(&x, stream, 4);
  if (x < kStateLow || x >= (kStateLow << 8))
    corrupt("initial state " + std::to_string(x) + " out of range");
  size_t pos = 4;
  uint8_t chunk[kChunk];
  uint64_t done = 0;
  while (done < n)
  {
    const size_t count = static_cast<size_t>(std::min<uint64_t>(kChunk, n - done));
    for (size_t i = 0; i < count; ++i)
    {
      const uint32_t slot = x & (kScale - 1u);
      const uint32_t s = slotSymbol[slot];
      // x < 2^32 and slot - start < freq: the result is at most freq * 2^17 - 1 < 2^32 (no overflow).
      x = t.freq[s] * (x >> kScaleBits) + slot - t.start[s];
      while (x < kStateLow)
      {
        if (pos >= streamBytes)
          corrupt("the stream ends after " + std::to_string(done + i) + " of " + std::to_string(n) + " symbols");
        x = (x << 8) | stream[pos++];
      }
      chunk[i] = static_cast<uint8_t>(s);
    }
    sink(chunk, count);
    done += count;
  }
  if (x != kStateLow)
    corrupt("the stream does not end in the encoder's initial state");
  for (; pos < streamBytes; ++pos)
    if (stream[pos] != 0)
      corrupt("non-zero bytes after the end of the stream");
  return t.bytes + t.streamBytes;
}

} // namespace nv
