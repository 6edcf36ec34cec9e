#include "vtkNeuralVolumeFile.h"

#include "Core/Error.h"
#include "Core/Model.h"
#include "Core/Serialization.h"

#include <cmath>
#include <cstring>
#include <fstream>

namespace vtkNeuralCompressInternals
{
namespace
{
const char kMagic[8] = { 'N', 'V', 'O', 'L', 'F', 'I', 'L', 'E' };

struct Out
{
  std::vector<uint8_t> bytes;
  template <typename T>
  void put(const T& v)
  {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  template <typename T>
  void put(const T* v, int n)
  {
    for (int i = 0; i < n; ++i)
      put(v[i]);
  }
};

struct In
{
  const uint8_t* data;
  size_t end;    ///< bytes readable (the file's size, then its size without the checksum)
  size_t at = 0; ///< the next byte to read
  void need(size_t k, const char* what)
  {
    if (k > end - at)
      NV_THROW(std::string("truncated NeuralVolume file: ") + what + " needs " + std::to_string(k) + " bytes at offset " +
        std::to_string(at) + ", " + std::to_string(end - at) + " left");
  }
  template <typename T>
  T get(const char* what)
  {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, data + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  template <typename T>
  void get(T* v, int k, const char* what)
  {
    for (int i = 0; i < k; ++i)
      v[i] = get<T>(what);
  }
};
/// The image of an entry: its extent holds one point per decoded sample (a cell array: one cell per sample, so one
/// point more on each axis but a flat one), at most nv::kMaxSourceSamples points in all.
void CheckExtent(const VolumeFileEntry& e)
{
  int64_t points = 1; // each axis below 2^20 + 1 points (checked before): no overflow
  for (int a = 0; a < 3; ++a)
  {
    const int64_t n = int64_t(e.Extent[2 * a + 1]) - e.Extent[2 * a] + 1;
    const int64_t samples = e.Cells && n > 1 ? n - 1 : n;
    NV_CHECK(samples == e.DecodedDims[a],
      "corrupt NeuralVolume file: the extent's " + std::to_string(n) + " points on axis " + "xyz"[a] + " hold " +
        std::to_string(samples) + (e.Cells ? " cells" : " points") + ", the entry decodes " +
        std::to_string(e.DecodedDims[a]));
    points *= n;
  }
  NV_CHECK(points <= nv::kMaxSourceSamples,
    "the image extent " + std::to_string(e.Extent[1] - e.Extent[0] + 1) + " x " +
      std::to_string(e.Extent[3] - e.Extent[2] + 1) + " x " + std::to_string(e.Extent[5] - e.Extent[4] + 1) + " (" +
      std::to_string(points) + " points) exceeds the 2^34 points a NeuralVolume image may have");
}
/// Version 2: the entry's piece, its bounds and the whole extent it is a piece of.
void ReadPiece(In& r, VolumeFileEntry& e)
{
  const uint32_t piece = r.get<uint32_t>("piece"), pieces = r.get<uint32_t>("pieces");
  NV_CHECK(pieces >= 1 && pieces <= 65536 && piece < pieces,
    "corrupt NeuralVolume file: piece " + std::to_string(piece) + " of " + std::to_string(pieces));
  e.Piece = static_cast<int>(piece);
  e.Pieces = static_cast<int>(pieces);
  r.get(e.PieceBounds, 6, "piece bounds");
  r.get(e.WholeExtent, 6, "whole extent");
  for (int a = 0; a < 3; ++a)
  {
    NV_CHECK(std::isfinite(e.PieceBounds[2 * a]) && std::isfinite(e.PieceBounds[2 * a + 1]),
      "corrupt NeuralVolume file: non-finite piece bounds");
    NV_CHECK(e.WholeExtent[2 * a] <= e.Extent[2 * a] && e.Extent[2 * a + 1] <= e.WholeExtent[2 * a + 1],
      "corrupt NeuralVolume file: a piece's extent outside the whole extent");
  }
}

/// The pieces of each time step agree on their count and whole extent, and none is there twice.
void CheckPieces(const std::vector<VolumeFileEntry>& entries)
{
  for (const auto& step : EntriesByTime(entries))
  {
    std::vector<bool> seen(static_cast<size_t>(step.front()->Pieces), false);
    for (const VolumeFileEntry* e : step)
    {
      NV_CHECK(std::equal(e->WholeExtent, e->WholeExtent + 6, step.front()->WholeExtent),
        "corrupt NeuralVolume file: the pieces of time " + std::to_string(e->Time) + " differ in their whole extent");
      NV_CHECK(!seen[static_cast<size_t>(e->Piece)],
        "corrupt NeuralVolume file: piece " + std::to_string(e->Piece) + " of time " + std::to_string(e->Time) +
          " is there twice");
      seen[static_cast<size_t>(e->Piece)] = true;
    }
  }
}
} // namespace

void CheckEntryAgainstNetwork(const VolumeFileEntry& e, const nv::SourceInfo& source)
{
  for (int a = 0; a < 3; ++a)
  {
    NV_CHECK(e.SourceDims[a] == source.dims[a],
      "the entry's source grid " + std::to_string(e.SourceDims[0]) + " x " + std::to_string(e.SourceDims[1]) + " x " +
        std::to_string(e.SourceDims[2]) + " is not its network's (" + std::to_string(source.dims[0]) + " x " +
        std::to_string(source.dims[1]) + " x " + std::to_string(source.dims[2]) + ")");
    NV_CHECK(!e.OnSourceGrid || e.DecodedDims[a] == e.SourceDims[a],
      "the entry's image is on the network's source grid but decodes " + std::to_string(e.DecodedDims[a]) +
        " samples on axis " + "xyz"[a] + " of its " + std::to_string(e.SourceDims[a]));
  }
  NV_CHECK(e.Cells == source.association, "the entry's association is not its network's");
}

std::vector<std::vector<const VolumeFileEntry*>> EntriesByTime(const std::vector<VolumeFileEntry>& entries)
{
  std::vector<std::vector<const VolumeFileEntry*>> groups;
  for (const VolumeFileEntry& e : entries)
  {
    const bool sameStep = !groups.empty() && e.Pieces > 1 && groups.back().front()->Pieces == e.Pieces &&
      groups.back().front()->Time == e.Time && static_cast<int>(groups.back().size()) < e.Pieces;
    if (!sameStep)
      groups.emplace_back();
    groups.back().push_back(&e);
  }
  return groups;
}

std::vector<uint8_t> WriteVolumeFile(const std::vector<VolumeFileEntry>& entries)
{
  NV_CHECK(!entries.empty() && entries.size() <= 65536, "a NeuralVolume file holds 1 to 65536 entries");
  bool distributed = false;
  for (const VolumeFileEntry& e : entries)
  {
    NV_CHECK(e.Pieces >= 1 && e.Pieces <= 65536 && e.Piece >= 0 && e.Piece < e.Pieces, "an entry's piece is invalid");
    distributed = distributed || e.Pieces > 1;
  }
  const uint32_t version = distributed ? 2u : 1u; // a serial run's file stays readable by earlier plugins
  Out o;
  o.bytes.insert(o.bytes.end(), kMagic, kMagic + 8);
  o.put<uint32_t>(version);
  o.put<uint32_t>(static_cast<uint32_t>(entries.size()));
  for (const VolumeFileEntry& e : entries)
  {
    NV_CHECK(!e.Network.empty(), "an entry without a network");
    o.put(e.Time);
    o.put(e.Extent, 6);
    o.put(e.Origin, 3);
    o.put(e.Spacing, 3);
    o.put(e.Direction, 9);
    o.put<int32_t>(e.Cells);
    o.put<int32_t>(e.VtkType);
    o.put(e.SourceDims, 3);
    o.put(e.DecodedDims, 3);
    o.put<int32_t>(e.OnSourceGrid);
    o.put(e.ValueRange, 2);
    o.put<uint32_t>(static_cast<uint32_t>(e.Name.size()));
    o.bytes.insert(o.bytes.end(), e.Name.begin(), e.Name.end());
    o.put<uint64_t>(e.Network.size());
    o.bytes.insert(o.bytes.end(), e.Network.begin(), e.Network.end());
    if (version >= 2)
    {
      o.put<uint32_t>(static_cast<uint32_t>(e.Piece));
      o.put<uint32_t>(static_cast<uint32_t>(e.Pieces));
      o.put(e.PieceBounds, 6);
      o.put(e.WholeExtent, 6);
    }
  }
  o.put<uint32_t>(nv::crc32(o.bytes.data(), o.bytes.size()));
  return o.bytes;
}

std::vector<VolumeFileEntry> ReadVolumeFile(const uint8_t* data, size_t size)
{
  if (!data || size < 8 || std::memcmp(data, kMagic, 8) != 0)
    NV_THROW("not a NeuralVolume (.nvol) file (" + std::to_string(size) + " bytes, bad magic)");
  In r{ data, size };
  r.at = 8;
  const uint32_t version = r.get<uint32_t>("version");
  if (version == 0 || version > kVolumeFileVersion)
    NV_THROW("NeuralVolume file version " + std::to_string(version) + " is not supported (this build reads versions "
      "1 to " + std::to_string(kVolumeFileVersion) + "; a newer plugin wrote it)");
  const uint32_t count = r.get<uint32_t>("entry count");
  if (count == 0 || count > 65536)
    NV_THROW("corrupt NeuralVolume file: " + std::to_string(count) + " entries");
  if (size < 20)
    NV_THROW("truncated NeuralVolume file (" + std::to_string(size) + " bytes)");
  uint32_t stored = 0;
  std::memcpy(&stored, data + size - 4, 4);
  if (nv::crc32(data, size - 4) != stored)
    NV_THROW("corrupt or truncated NeuralVolume file: checksum mismatch over " + std::to_string(size) + " bytes");
  r.end = size - 4;
  std::vector<VolumeFileEntry> out(count);
  for (VolumeFileEntry& e : out)
  {
    e.Time = r.get<double>("time");
    r.get(e.Extent, 6, "extent");
    r.get(e.Origin, 3, "origin");
    r.get(e.Spacing, 3, "spacing");
    r.get(e.Direction, 9, "direction");
    e.Cells = r.get<int32_t>("association");
    e.VtkType = r.get<int32_t>("type");
    r.get(e.SourceDims, 3, "source dims");
    r.get(e.DecodedDims, 3, "decoded dims");
    e.OnSourceGrid = r.get<int32_t>("on source grid");
    r.get(e.ValueRange, 2, "value range");
    const uint32_t nameBytes = r.get<uint32_t>("name length");
    NV_CHECK(nameBytes <= 4096, "corrupt NeuralVolume file: an array name of " + std::to_string(nameBytes) + " bytes");
    r.need(nameBytes, "name");
    e.Name.assign(reinterpret_cast<const char*>(data + r.at), nameBytes);
    r.at += nameBytes;
    const uint64_t networkBytes = r.get<uint64_t>("network length");
    r.need(static_cast<size_t>(std::min<uint64_t>(networkBytes, uint64_t(1) << 62)), "network");
    e.Network.assign(data + r.at, data + r.at + networkBytes);
    r.at += networkBytes;
    if (version >= 2)
      ReadPiece(r, e);
    else
      std::copy(e.Extent, e.Extent + 6, e.WholeExtent);
    bool finite = std::isfinite(e.Time) && std::isfinite(e.ValueRange[0]) && std::isfinite(e.ValueRange[1]);
    for (int a = 0; a < 3; ++a)
    {
      finite = finite && std::isfinite(e.Origin[a]) && std::isfinite(e.Spacing[a]);
      const int span = e.Extent[2 * a + 1] - e.Extent[2 * a];
      NV_CHECK(span >= 0 && span < (1 << 20) && e.DecodedDims[a] >= 1 && e.DecodedDims[a] <= span + 1 &&
          e.SourceDims[a] >= 1 && e.SourceDims[a] < (1 << 20),
        "corrupt NeuralVolume file: inconsistent extent and dimensions");
    }
    NV_CHECK(finite, "corrupt NeuralVolume file: non-finite geometry, time or range");
    NV_CHECK(e.Cells == 0 || e.Cells == 1, "corrupt NeuralVolume file: unknown association");
    CheckExtent(e);
  }
  NV_CHECK(r.at == r.end, "corrupt NeuralVolume file: " + std::to_string(r.end - r.at) + " unexpected trailing bytes");
  CheckPieces(out);
  return out;
}

std::vector<uint8_t> ReadFileBytes(const std::string& path)
{
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  NV_CHECK(f.good(), "cannot open '" + path + "'");
  const std::streamoff size = f.tellg();
  NV_CHECK(size >= 0 && size <= (std::streamoff(1) << 32), "'" + path + "' is not a readable file of at most 4 GiB");
  std::vector<uint8_t> b(static_cast<size_t>(size));
  f.seekg(0);
  f.read(reinterpret_cast<char*>(b.data()), size);
  NV_CHECK(f.good() || size == 0, "failed reading '" + path + "'");
  return b;
}

} // namespace vtkNeuralCompressInternals
