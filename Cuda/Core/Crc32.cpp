// The CRC-32 of the model format (Serialization.h): reflected polynomial 0xEDB88320, sliced by 8.
#include "Serialization.h"

#include <cstring>

namespace nv
{
namespace
{
/// Slicing-by-8 tables of the reflected CRC-32 polynomial (built once, thread-safe).
struct CrcTables
{
  uint32_t table[8][256]; ///< [0]: the byte-wise table; [s]: a byte carried through s more bytes
  CrcTables()
  {
    for (uint32_t i = 0; i < 256; ++i)
    {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k)
        c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      table[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; ++i)
      for (int s = 1; s < 8; ++s)
        table[s][i] = (table[s - 1][i] >> 8) ^ table[0][table[s - 1][i] & 0xFFu];
  }
};

} // namespace

uint32_t crc32(const uint8_t* data, size_t size)
{
  static const CrcTables tables;
  const auto& t = tables.table;
  uint32_t c = 0xFFFFFFFFu;
  size_t i = 0;
  for (; i + 8 <= size; i += 8)
  {
    uint32_t lo, hi;
    std::memcpy(&lo, data + i, 4); // little endian (checked by the format)
    std::memcpy(&hi, data + i + 4, 4);
    lo ^= c;
    c = t[7][lo & 0xFFu] ^ t[6][(lo >> 8) & 0xFFu] ^ t[5][(lo >> 16) & 0xFFu] ^ t[4][lo >> 24] ^
      t[3][hi & 0xFFu] ^ t[2][(hi >> 8) & 0xFFu] ^ t[1][(hi >> 16) & 0xFFu] ^ t[0][hi >> 24];
  }
  for (; i < size; ++i)
    c = t[0][(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

} // namespace nv
