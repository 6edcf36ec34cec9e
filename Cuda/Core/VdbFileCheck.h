// NeuralVolume engine: checks an OpenVDB (.vdb) file's headers against its size before OpenVDB reads it.
//
// OpenVDB's reader trusts the lengths and offsets it reads: a truncated or corrupt file makes it allocate strings of
// garbage lengths (gigabytes) or seek past the end and read on. This check reads only the headers, each field against
// the bytes present, and allocates nothing in proportion to what they claim. The layout (little endian):
//   header        i64 magic 0x56444220 ("VDB "), u32 format version (213 to 224 here), u32 library major and minor,
//                 u8 "has grid offsets" (0 or 1), [format 220-221: u8 compressed], the UUID (format 218 and later:
//                 36 ASCII characters; before: 16 bytes)
//   file metadata u32 count, per entry: string name, string type name, u32 size, size bytes
//   grid count    i32
//   per grid      descriptor: string unique name, string type name (suffix "_HalfFloat": stored as half), [format
//                 216 and later: string instance parent name], i64 grid, block and end positions; then at the grid
//                 position: [format 222 and later: u32 compression flags], the grid's metadata (as the file's),
//                 [format 219 and later: string transform type], the transform, topology and (from the block
//                 position) data blocks up to the end position, where the next descriptor starts
// A string is a u32 length and as many bytes. What is checked: the magic, the version, every string length and count
// against the bytes left (type names printable, at most 256 bytes), metadata of a fixed-size type against its size,
// each grid's positions (the grid starts where its descriptor ends; descriptor < grid < block <= end <= file size;
// an instance's block position may be 0), its head within its own bytes. A streamed file (no grid offsets) has its
// first grid's descriptor and head checked only. Grid data (topology, blocks) is not parsed.
#pragma once

#include "VdbFileSummary.h"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace nv
{

/// One check of one file's bytes; throws nv::Error naming what is wrong (e.g. "the file ends at byte N but its grid
/// 'density' claims bytes up to M: the file is truncated"). Memory: a few strings of at most kKeptChars bytes.
class VdbFileCheck
{
public:
  static constexpr uint32_t kOldestVersion = 213; ///< the oldest format version accepted (root node maps)
  static constexpr uint32_t kNewestVersion = 224; ///< the newest format version accepted (OpenVDB 10: 224)
  static constexpr uint32_t kMaxTypeNameBytes = 256;
  static constexpr size_t kKeptChars = 200; ///< bytes kept of a name (summary and messages)

  /// Copies the `n` bytes at `offset` into `dst` (never past the size given to the check); false on a read error.
  using ReadAt = std::function<bool(uint64_t offset, void* dst, size_t n)>;

  VdbFileCheck(ReadAt readAt, uint64_t fileSize);

  /// The summary of the whole file (once per object).
  VdbFileSummary run();

  /// The check of `size` bytes in memory.
  static VdbFileSummary checkBytes(const uint8_t* data, size_t size);
  /// The check of a file (a regular file; read through a stream, never loaded whole).
  static VdbFileSummary checkFile(const std::string& path);

private:
  void need(uint64_t n, const std::string& what) const;
  void bytes(void* dst, size_t n, const std::string& what);
  uint8_t u8(const std::string& what);
  uint32_t u32(const std::string& what);
  int64_t i64(const std::string& what);
  std::string text(const std::string& what, uint32_t maxBytes, bool typeName);
  void readHeader(VdbFileSummary& s);
  uint32_t readMetadata(const std::string& owner);
  void readMetadataEntry(const std::string& owner, uint32_t index);
  VdbFileSummary::Grid readDescriptor(uint32_t version, int32_t index);
  void checkPositions(const VdbFileSummary::Grid& g) const;
  void readGridHead(VdbFileSummary::Grid& g, uint32_t version);

  ReadAt readAt_;
  uint64_t size_;
  uint64_t pos_ = 0;
  uint64_t limit_;         ///< reads end here: the file's size, or the bytes of the grid being read
  std::string limitWhat_;  ///< what ends at limit_ when it is not the file's end
};

} // namespace nv
