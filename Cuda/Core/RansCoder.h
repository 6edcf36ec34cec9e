// NeuralVolume engine: a static-frequency rANS entropy coder of 8-bit symbols (Precision::Quantized8 networks).
//
// A coded block (little endian):
//   u8   K - 1           symbols 0..K-1 have a frequency (K = 1..256; symbols >= K never occur)
//   K x  varint          their frequencies (LEB128, each 0..kScale, the last one > 0), summing to kScale exactly
//   u32  S               stream bytes
//   S x  u8              the rANS stream: the 32-bit final state of the encoder (little endian), the renormalisation
//                        bytes in the order the decoder reads them, then zero bytes up to at least
//                        minStreamBytes(n)
// The decoder knows how many symbols it decodes (n comes from the model's configuration). The stream is padded so
// that it holds at least one byte per kMaxSymbolsPerByte symbols: n is at most kMaxSymbolsPerByte times the bytes
// present, so a hostile file cannot make a reader allocate much more than its own size. Every read is bounds-checked;
// the table is validated (sum, canonical last symbol), a frequency of 0 is never decoded (the slots cover exactly the
// symbols with a frequency), and a stream must end in the encoder's initial state followed by zero padding. Every
// failure is an nv::Error.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace nv
{

class RansCoder
{
public:
  static constexpr int kScaleBits = 15;
  static constexpr uint32_t kScale = 1u << kScaleBits; ///< frequencies of a table sum to this
  static constexpr uint64_t kMaxSymbolsPerByte = 1024; ///< the stream holds at least n / this bytes (after 4)

  /// Bytes a stream of n symbols holds at least: the 4-byte state and one byte per kMaxSymbolsPerByte symbols.
  static uint64_t minStreamBytes(uint64_t n) { return 4 + n / kMaxSymbolsPerByte; }

  /// Appends the coded block of `n` symbols to `out` (deterministic: the same symbols give the same bytes).
  static void encode(const uint8_t* symbols, size_t n, std::vector<uint8_t>& out);

  /// Checks the block of `n` symbols at data[0..size) without decoding it: the table and the stream's length (against
  /// the bytes present and minStreamBytes(n)). Returns the block's bytes. Allocates nothing.
  static size_t inspect(const uint8_t* data, size_t size, uint64_t n);

  /// Called with the decoded symbols in order, in pieces of at most 4096.
  using Sink = std::function<void(const uint8_t* symbols, size_t count)>;
  /// Decodes the block of `n` symbols at data[0..size) into `sink`. Returns the block's bytes. Throws nv::Error on a
  /// corrupt table or stream (the sink may have received part of the symbols then).
  static size_t decode(const uint8_t* data, size_t size, uint64_t n, const Sink& sink);

  /// Frequencies (summing to kScale, every symbol that occurs > 0) for symbol counts `counts[256]` of `n` symbols.
  static void normalize(const uint64_t counts[256], uint64_t n, uint32_t freq[256]);
};

} // namespace nv
