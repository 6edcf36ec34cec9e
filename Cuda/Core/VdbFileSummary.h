// NeuralVolume engine: what the headers of an OpenVDB (.vdb) file promise, as VdbFileCheck found them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace nv
{

/// The layout of a .vdb file checked against its size (VdbFileCheck.h). Strings are kept to at most
/// VdbFileCheck::kKeptChars bytes (longer ones end in "..."), non-printable bytes as '?'.
struct VdbFileSummary
{
  /// One grid descriptor and the head of its grid (compression flags, metadata, transform type).
  struct Grid
  {
    std::string name;           ///< the unique name as stored (a "\x1e<n>" suffix shown as '?')
    std::string type;           ///< the tree type, without the "_HalfFloat" suffix (e.g. "Tree_float_5_4_3")
    bool halfFloat = false;     ///< the type ended in "_HalfFloat"
    std::string instanceParent; ///< empty unless the grid shares another grid's tree
    uint64_t descriptorPos = 0; ///< byte where the descriptor starts
    uint64_t gridPos = 0;       ///< byte where the grid (compression, metadata, transform, topology) starts
    uint64_t blockPos = 0;      ///< byte where its data blocks start (0 for an instance)
    uint64_t endPos = 0;        ///< byte just past the grid: the next descriptor, or the end of the file
    uint32_t compression = 0;   ///< compression flags (format 222 and later; 0 before)
    uint32_t metadataCount = 0; ///< entries of the grid's metadata
    std::string transformType;  ///< e.g. "UniformScaleTranslateMap" (format 219 and later)
  };

  uint64_t fileSize = 0;
  uint32_t formatVersion = 0;
  uint32_t libraryMajor = 0, libraryMinor = 0;
  /// False for a streamed file (written without grid offsets): only its first grid's descriptor and head are
  /// checked (its end is known only to the tree's reader), and that grid's blockPos and endPos are 0.
  bool hasGridOffsets = true;
  uint32_t metadataCount = 0; ///< entries of the file's metadata
  int32_t gridCount = 0;      ///< grids the file declares
  std::vector<Grid> grids;    ///< the grids checked, in file order
};

} // namespace nv
