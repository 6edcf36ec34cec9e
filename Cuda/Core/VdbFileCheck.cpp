#include "VdbFileCheck.h"

#include "Error.h"

#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace nv
{

namespace
{
constexpr int64_t kMagic = 0x56444220; // "VDB " in the low 4 bytes, little endian
constexpr uint32_t kVersionGridInstancing = 216;
constexpr uint32_t kVersionUuidText = 218;
constexpr uint32_t kVersionNewTransform = 219;
constexpr uint32_t kVersionSelectiveCompression = 220;
constexpr uint32_t kVersionGridCompression = 222;
constexpr uint32_t kMaxCompressionFlags = 7; // zip 1 | active mask 2 | blosc 4
constexpr uint64_t kMinMetadataEntry = 12;   // empty name, empty type, size 0 (a lower bound)
constexpr uint64_t kDescriptorOffsets = 24;  // grid, block and end positions

std::string number(uint64_t v)
{
  return std::to_string(v);
}

/// Printable, clipped text of stored bytes (a name in a message never carries control characters or megabytes).
std::string shown(const char* data, size_t n, bool clipped)
{
  std::string s(data, n);
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e)
      c = '?';
  return clipped ? s + "..." : s;
}

/// A name in a message: quoted, at most 60 characters of it.
std::string inQuotes(const std::string& name)
{
  return "'" + (name.size() > 60 ? name.substr(0, 60) + "..." : name) + "'";
}

/// Bytes a metadata value of a known fixed-size type holds (0: any size, e.g. strings or unknown types).
uint32_t fixedMetadataSize(const std::string& type)
{
  static const struct
  {
    const char* type;
    uint32_t bytes;
  } known[] = { { "bool", 1 }, { "int32", 4 }, { "int64", 8 }, { "float", 4 }, { "double", 8 }, { "vec2i", 8 },
    { "vec2s", 8 }, { "vec2d", 16 }, { "vec3i", 12 }, { "vec3s", 12 }, { "vec3d", 24 }, { "vec4i", 16 },
    { "vec4s", 16 }, { "vec4d", 32 }, { "mat4s", 64 }, { "mat4d", 128 } };
  for (const auto& k : known)
    if (type == k.type)
      return k.bytes;
  return 0;
}
} // namespace

VdbFileCheck::VdbFileCheck(ReadAt readAt, uint64_t fileSize)
  : readAt_(std::move(readAt))
  , size_(fileSize)
  , limit_(fileSize)
{
}

void VdbFileCheck::need(uint64_t n, const std::string& what) const
{
  if (n <= limit_ && pos_ <= limit_ - n)
    return;
  const uint64_t end = n > ~uint64_t(0) - pos_ ? ~uint64_t(0) : pos_ + n;
  if (limit_ == size_)
    NV_THROW("the file ends at byte " + number(size_) + " but " + what + " at byte " + number(pos_) +
      " needs bytes up to " + number(end) + ": the file is truncated");
  NV_THROW(what + " at byte " + number(pos_) + " needs bytes up to " + number(end) + ", past the end of " + limitWhat_ +
    " at byte " + number(limit_) + ": the file is corrupt");
}

void VdbFileCheck::bytes(void* dst, size_t n, const std::string& what)
{
  need(n, what);
  if (n > 0 && !readAt_(pos_, dst, n))
    NV_THROW("cannot read " + what + " at byte " + number(pos_) + " (a read error)");
  pos_ += n;
}

uint8_t VdbFileCheck::u8(const std::string& what)
{
  uint8_t v = 0;
  bytes(&v, 1, what);
  return v;
}

uint32_t VdbFileCheck::u32(const std::string& what)
{
  uint8_t b[4];
  bytes(b, 4, what);
  return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
}

int64_t VdbFileCheck::i64(const std::string& what)
{
  uint8_t b[8];
  bytes(b, 8, what);
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i)
    v = v << 8 | b[i];
  return static_cast<int64_t>(v);
}

/// A length-prefixed string: the length must fit in the bytes left; kept to kKeptChars bytes (type names: whole,
/// at most maxBytes, printable, not empty).
std::string VdbFileCheck::text(const std::string& what, uint32_t maxBytes, bool typeName)
{
  const uint64_t at = pos_;
  const uint32_t length = u32("the length of " + what);
  if (length > limit_ - pos_)
    NV_THROW("the length of " + what + " at byte " + number(at) + " is " + number(length) + " bytes, past the end of " +
      (limit_ == size_ ? "the file at byte " + number(size_) + ": the file is truncated or corrupt"
                       : limitWhat_ + " at byte " + number(limit_) + ": the file is corrupt"));
  if (length > maxBytes || (typeName && length == 0))
    NV_THROW("the length of " + what + " at byte " + number(at) + " is " + number(length) + " bytes, not 1 to " +
      number(maxBytes) + ": the file is corrupt");
  const size_t kept = length < kKeptChars || typeName ? length : kKeptChars;
  char buffer[kMaxTypeNameBytes > kKeptChars ? kMaxTypeNameBytes : kKeptChars];
  bytes(buffer, kept, what);
  pos_ += length - kept;
  if (typeName)
    for (size_t i = 0; i < kept; ++i)
      if (static_cast<unsigned char>(buffer[i]) < 0x20 || static_cast<unsigned char>(buffer[i]) > 0x7e)
        NV_THROW(what + " at byte " + number(at + 4) + " holds a non-printable byte (" +
          number(static_cast<unsigned char>(buffer[i])) + "): the file is corrupt");
  return shown(buffer, kept, kept < length);
}

void VdbFileCheck::readHeader(VdbFileSummary& s)
{
  if (size_ == 0)
    NV_THROW("the file is empty (0 bytes): not an OpenVDB file");
  if (size_ < 8)
    NV_THROW("the file has only " + number(size_) + " bytes, fewer than OpenVDB's 8-byte magic number: not an "
      "OpenVDB file, or one truncated");
  const int64_t magic = i64("the magic number");
  if (magic != kMagic)
    NV_THROW("not an OpenVDB file: its first 8 bytes are not the magic number 0x56444220 (\"VDB \")");
  s.formatVersion = u32("the format version");
  if (s.formatVersion < kOldestVersion || s.formatVersion > kNewestVersion)
    NV_THROW("format version " + number(s.formatVersion) + " is not one this reader accepts (" +
      number(kOldestVersion) + " to " + number(kNewestVersion) + "): the file is corrupt or from a newer OpenVDB");
  s.libraryMajor = u32("the library major version");
  s.libraryMinor = u32("the library minor version");
  const uint8_t offsets = u8("the 'has grid offsets' flag");
  if (offsets > 1)
    NV_THROW("the 'has grid offsets' flag at byte 20 is " + number(offsets) + ", not 0 or 1: the file is corrupt");
  s.hasGridOffsets = offsets == 1;
  if (s.formatVersion >= kVersionSelectiveCompression && s.formatVersion < kVersionGridCompression)
  {
    const uint8_t compressed = u8("the 'compressed' flag");
    if (compressed > 1)
      NV_THROW("the 'compressed' flag at byte 21 is " + number(compressed) + ", not 0 or 1: the file is corrupt");
  }
  if (s.formatVersion < kVersionUuidText)
  {
    uint8_t uuid[16];
    bytes(uuid, sizeof(uuid), "the UUID");
    return;
  }
  const uint64_t at = pos_;
  char uuid[36];
  bytes(uuid, sizeof(uuid), "the UUID");
  for (size_t i = 0; i < sizeof(uuid); ++i)
    if (!std::isxdigit(static_cast<unsigned char>(uuid[i])) && uuid[i] != '-')
      NV_THROW("the UUID at byte " + number(at) + " holds a byte (" + number(static_cast<unsigned char>(uuid[i])) +
        ") that is neither a hexadecimal digit nor '-': the file is corrupt");
}

void VdbFileCheck::readMetadataEntry(const std::string& owner, uint32_t index)
{
  const std::string entry = "metadata entry " + number(index) + " of " + owner;
  const std::string name = text("the name of " + entry, ~uint32_t(0), false);
  const std::string type = text("the type name of " + entry + " (" + inQuotes(name) + ")", kMaxTypeNameBytes, true);
  const uint64_t at = pos_;
  const uint32_t size = u32("the size of " + entry + " (" + inQuotes(name) + ")");
  const uint32_t fixed = fixedMetadataSize(type);
  if (fixed != 0 && size != fixed)
    NV_THROW("metadata " + inQuotes(name) + " of " + owner + " is a " + type + " of " + number(size) + " bytes (at byte " +
      number(at) + "), not " + number(fixed) + ": the file is corrupt");
  need(size, "the value of metadata " + inQuotes(name) + " of " + owner);
  pos_ += size;
}

uint32_t VdbFileCheck::readMetadata(const std::string& owner)
{
  const uint64_t at = pos_;
  const uint32_t count = u32("the metadata count of " + owner);
  if (count > (limit_ - pos_) / kMinMetadataEntry)
    NV_THROW("the metadata count of " + owner + " at byte " + number(at) + " is " + number(count) + ", more than " +
      number(limit_ - pos_) + " bytes can hold: the file is " +
      (limit_ == size_ ? "truncated or corrupt" : "corrupt"));
  for (uint32_t i = 0; i < count; ++i)
    readMetadataEntry(owner, i);
  return count;
}

VdbFileSummary::Grid VdbFileCheck::readDescriptor(uint32_t version, int32_t index)
{
  VdbFileSummary::Grid g;
  g.descriptorPos = pos_;
  const std::string which = "grid descriptor " + number(uint64_t(index));
  g.name = text("the name in " + which, ~uint32_t(0), false);
  const std::string owner = which + " (" + inQuotes(g.name) + ")";
  g.type = text("the grid type of " + owner, kMaxTypeNameBytes, true);
  static const std::string half = "_HalfFloat";
  if (g.type.size() > half.size() && g.type.compare(g.type.size() - half.size(), half.size(), half) == 0)
  {
    g.halfFloat = true;
    g.type.resize(g.type.size() - half.size());
  }
  if (version >= kVersionGridInstancing)
    g.instanceParent = text("the instance parent name of " + owner, ~uint32_t(0), false);
  const int64_t positions[3] = { i64("the grid position of " + owner), i64("the block position of " + owner),
    i64("the end position of " + owner) };
  for (int i = 0; i < 3; ++i)
    if (positions[i] < 0)
      NV_THROW(owner + " holds a negative byte position (" + std::to_string(positions[i]) + "): the file is corrupt");
  g.gridPos = uint64_t(positions[0]);
  g.blockPos = uint64_t(positions[1]);
  g.endPos = uint64_t(positions[2]);
  return g;
}

void VdbFileCheck::checkPositions(const VdbFileSummary::Grid& g) const
{
  const std::string grid = "grid " + inQuotes(g.name);
  if (g.gridPos != pos_)
    NV_THROW("the descriptor of " + grid + " ends at byte " + number(pos_) + " but says the grid starts at byte " +
      number(g.gridPos) + ": the file is corrupt");
  if (g.endPos > size_)
    NV_THROW("the file ends at byte " + number(size_) + " but its " + grid + " claims bytes up to " +
      number(g.endPos) + ": the file is truncated");
  if (g.endPos <= g.gridPos)
    NV_THROW(grid + " ends at byte " + number(g.endPos) + ", not after its start at byte " + number(g.gridPos) +
      ": the file is corrupt");
  const bool instance = !g.instanceParent.empty();
  if (instance ? g.blockPos != 0 && (g.blockPos < g.gridPos || g.blockPos > g.endPos)
               : g.blockPos <= g.gridPos || g.blockPos > g.endPos)
    NV_THROW("the data blocks of " + grid + " start at byte " + number(g.blockPos) + ", outside its bytes " +
      number(g.gridPos) + " to " + number(g.endPos) + ": the file is corrupt");
}

void VdbFileCheck::readGridHead(VdbFileSummary::Grid& g, uint32_t version)
{
  const std::string grid = "grid " + inQuotes(g.name);
  if (version >= kVersionGridCompression)
  {
    const uint64_t at = pos_;
    g.compression = u32("the compression flags of " + grid);
    if (g.compression > kMaxCompressionFlags)
      NV_THROW("the compression flags of " + grid + " at byte " + number(at) + " are " + number(g.compression) +
        ", not 0 to 7: the file is corrupt");
  }
  g.metadataCount = readMetadata(grid);
  if (version >= kVersionNewTransform)
    g.transformType = text("the transform type of " + grid, kMaxTypeNameBytes, true);
}

VdbFileSummary VdbFileCheck::run()
{
  VdbFileSummary s;
  s.fileSize = size_;
  readHeader(s);
  s.metadataCount = readMetadata("the file");
  const uint64_t at = pos_;
  s.gridCount = static_cast<int32_t>(u32("the grid count"));
  const uint64_t minDescriptor = 4 * (s.formatVersion >= kVersionGridInstancing ? 3 : 2) + 4 + kDescriptorOffsets;
  if (s.gridCount < 0 || uint64_t(s.gridCount) > (size_ - pos_) / minDescriptor)
    NV_THROW("the grid count at byte " + number(at) + " is " + std::to_string(s.gridCount) + ", " +
      (s.gridCount < 0 ? std::string("negative") : "more than the " + number(size_ - pos_) + " bytes left can hold") +
      ": the file is " + (s.gridCount < 0 ? "corrupt" : "truncated or corrupt"));
  for (int32_t i = 0; i < s.gridCount; ++i)
  {
    VdbFileSummary::Grid g = readDescriptor(s.formatVersion, i);
    if (!s.hasGridOffsets)
    {
      if (g.gridPos != 0 || g.blockPos != 0 || g.endPos != 0)
        NV_THROW("the file says it has no grid offsets, but the descriptor of grid " + inQuotes(g.name) +
          " holds byte positions: the file is corrupt");
      g.gridPos = pos_;
      readGridHead(g, s.formatVersion); // a streamed file: the next descriptor follows the tree, unparsed here
      s.grids.push_back(g);
      break;
    }
    checkPositions(g);
    limit_ = g.instanceParent.empty() ? g.blockPos : g.endPos;
    limitWhat_ = "the head of grid " + inQuotes(g.name) + " (its " + (g.instanceParent.empty() ? "block" : "end") +
      " position)";
    readGridHead(g, s.formatVersion);
    limit_ = size_;
    pos_ = g.endPos;
    s.grids.push_back(g);
  }
  return s;
}

VdbFileSummary VdbFileCheck::checkBytes(const uint8_t* data, size_t size)
{
  VdbFileCheck check(
    [data, size](uint64_t offset, void* dst, size_t n) {
      if (offset > size || n > size - offset)
        return false;
      std::memcpy(dst, data + offset, n);
      return true;
    },
    size);
  return check.run();
}

VdbFileSummary VdbFileCheck::checkFile(const std::string& path)
{
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status))
    NV_THROW("cannot open the file" + (error ? " (" + error.message() + ")" : std::string()));
  if (!std::filesystem::is_regular_file(status))
    NV_THROW("not a regular file");
  const uint64_t size = std::filesystem::file_size(path, error);
  if (error)
    NV_THROW("cannot get the file's size (" + error.message() + ")");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    NV_THROW("cannot open the file for reading");
  uint64_t at = 0; // the stream's position: sequential reads keep its buffer
  VdbFileCheck check(
    [&in, &at, size](uint64_t offset, void* dst, size_t n) {
      if (offset > size || n > size - offset)
        return false;
      if (offset != at)
      {
        in.clear();
        in.seekg(static_cast<std::streamoff>(offset));
      }
      in.read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
      at = offset + n;
      return in.good() && in.gcount() == static_cast<std::streamsize>(n);
    },
    size);
  return check.run();
}

} // namespace nv
