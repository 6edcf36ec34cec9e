// Small, valid OpenVDB file layouts for the tests of nv::VdbFileCheck (Testing/Engine) and the seeds of its fuzz
// target (Testing/Fuzz): the real header, metadata and grid descriptors of OpenVDB's format (see
// Cuda/Core/VdbFileCheck.h), each grid's head (compression flags, metadata, transform type), and filler bytes in
// place of the transform's values, the topology and the data blocks (the check does not parse them).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace nvtest
{

class SyntheticVdb
{
public:
  struct Grid
  {
    std::string name = "density";
    std::string type = "Tree_float_5_4_3";
    bool halfFloat = false;
    std::string instanceParent;  ///< non-empty: an instance (no topology or blocks; block position 0)
    uint32_t topologyBytes = 40; ///< filler after the transform type (its values and the topology)
    uint32_t blockBytes = 64;    ///< filler of the data blocks
    // Filled by build():
    uint64_t descriptorPos = 0, gridPos = 0, blockPos = 0, endPos = 0;
  };

  uint32_t version = 224;
  bool hasGridOffsets = true;
  std::vector<Grid> grids = { Grid() };
  std::vector<std::pair<std::string, std::string>> fileStrings = { { "creator", "NeuralVolume test" } };

  /// The file's bytes; sets each grid's positions.
  std::vector<uint8_t> build()
  {
    out_.clear();
    put64(0x56444220);
    put32(version);
    put32(10);
    put32(0);
    out_.push_back(hasGridOffsets ? 1 : 0);
    if (version >= 220 && version < 222)
      out_.push_back(1);
    const std::string uuid = "0123ABCD-4567-89EF-0123-456789ABCDEF";
    if (version >= 218)
      putRaw(uuid);
    else
      putRaw(std::string(16, '\x5a'));
    put32(uint32_t(fileStrings.size()));
    for (const auto& kv : fileStrings)
      putMeta(kv.first, "string", kv.second);
    put32(uint32_t(grids.size()));
    for (Grid& g : grids)
      putGrid(g);
    return out_;
  }

private:
  void put32(uint32_t v)
  {
    for (int i = 0; i < 4; ++i)
      out_.push_back(uint8_t(v >> (8 * i)));
  }
  void put64(uint64_t v)
  {
    for (int i = 0; i < 8; ++i)
      out_.push_back(uint8_t(v >> (8 * i)));
  }
  void set64(uint64_t at, uint64_t v)
  {
    for (int i = 0; i < 8; ++i)
      out_[at + i] = uint8_t(v >> (8 * i));
  }
  void putRaw(const std::string& s) { out_.insert(out_.end(), s.begin(), s.end()); }
  void putString(const std::string& s)
  {
    put32(uint32_t(s.size()));
    putRaw(s);
  }
  void putMeta(const std::string& name, const std::string& type, const std::string& value)
  {
    putString(name);
    putString(type);
    putString(value); // a size and the value's bytes
  }
  void filler(uint32_t n, uint8_t seed)
  {
    for (uint32_t i = 0; i < n; ++i)
      out_.push_back(uint8_t(seed + 37 * i));
  }
  void putGrid(Grid& g)
  {
    g.descriptorPos = out_.size();
    putString(g.name);
    putString(g.type + (g.halfFloat ? "_HalfFloat" : ""));
    if (version >= 216)
      putString(g.instanceParent);
    const uint64_t offsets = out_.size();
    put64(0);
    put64(0);
    put64(0);
    g.gridPos = hasGridOffsets ? out_.size() : 0;
    if (version >= 222)
      put32(2); // active-mask compression
    put32(5);
    putMeta("class", "string", "fog volume");
    putMeta("file_bbox_min", "vec3i", std::string(12, '\0'));
    putMeta("file_voxel_count", "int64", std::string(8, '\x07'));
    putMeta("is_saved_as_half_float", "bool", std::string(1, g.halfFloat ? '\1' : '\0'));
    putMeta("name", "string", g.name);
    if (version >= 219)
      putString("UniformScaleTranslateMap");
    const bool instance = !g.instanceParent.empty();
    filler(instance ? 48 : g.topologyBytes, 11);
    g.blockPos = hasGridOffsets && !instance ? out_.size() : 0;
    if (!instance)
      filler(g.blockBytes, 5);
    g.endPos = hasGridOffsets ? out_.size() : 0;
    set64(offsets, g.gridPos);
    set64(offsets + 8, g.blockPos);
    set64(offsets + 16, g.endPos);
  }

  std::vector<uint8_t> out_;
};

} // namespace nvtest
