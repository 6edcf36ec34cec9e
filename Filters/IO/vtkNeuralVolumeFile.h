// The .nvol file (private header, free of VTK): trained networks of Neural Compress with the geometry of their
// output image, one entry per time step (and per piece: a distributed run's file). Little endian:
//   "NVOLFILE" | u32 version (1 or 2) | u32 entry count (1..65536) | entries | u32 CRC-32 of everything before it
// entry: f64 time | i32 extent[6] | f64 origin[3] | f64 spacing[3] | f64 direction[9] | i32 cells (0 point,
//   1 cell) | i32 VTK type of the source array | i32 source dims[3] | i32 decoded dims[3] | i32 on source grid |
//   f64 value range[2] | u32 name length, name bytes | u64 network length, network (the engine's model format,
//   with its own version and CRC-32; Cuda/Core/Serialization.h)
//   version 2 only, then: u32 piece | u32 pieces (1..65536) | f64 piece bounds[6] | i32 whole extent[6]
// Version 2 holds the networks of a run under MPI (one network per rank, issue 23): entry `piece` of `pieces` is
// rank `piece`'s network, its image (extent: the rank's own piece of `whole extent`) and the bounds its rays are
// clipped to (NeuralPieceBounds). A file of one piece per time step is written as version 1, as before.
// Readers accept every version up to kVolumeFileVersion; every size is checked before it is used.
#ifndef vtkNeuralVolumeFile_h
#define vtkNeuralVolumeFile_h

#include <cstdint>
#include <string>
#include <vector>

namespace nv
{
struct SourceInfo;
}

namespace vtkNeuralCompressInternals
{

constexpr uint32_t kVolumeFileVersion = 2;

struct VolumeFileEntry
{
  double Time = 0.0;
  int Extent[6] = { 0, 0, 0, 0, 0, 0 };
  double Origin[3] = { 0, 0, 0 };
  double Spacing[3] = { 1, 1, 1 };
  double Direction[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
  int Cells = 0;
  int VtkType = 0;
  int SourceDims[3] = { 1, 1, 1 };
  int DecodedDims[3] = { 1, 1, 1 };
  int OnSourceGrid = 1;
  double ValueRange[2] = { 0, 1 };
  std::string Name;
  std::vector<uint8_t> Network;
  // Version 2: a rank's piece of a distributed run (piece 0 of 1 otherwise, whole extent = extent).
  int Piece = 0;
  int Pieces = 1;
  double PieceBounds[6] = { 0, -1, 0, -1, 0, -1 }; ///< NeuralPieceBounds of the piece (empty: none)
  int WholeExtent[6] = { 0, 0, 0, 0, 0, 0 };
};

/// The entries of one time step of a file: the first entry of each time (several: the pieces of a distributed run,
/// in piece order).
std::vector<std::vector<const VolumeFileEntry*>> EntriesByTime(const std::vector<VolumeFileEntry>& entries);

/// Version 1 when every entry is piece 0 of 1, else version 2.
std::vector<uint8_t> WriteVolumeFile(const std::vector<VolumeFileEntry>& entries);
/// Throws nv::Error with a clear message on a file that is not an .nvol, of a newer version, truncated or corrupt
/// (also: pieces of a time step that disagree on their count or whole extent, or a piece twice).
std::vector<VolumeFileEntry> ReadVolumeFile(const uint8_t* data, size_t size);
/// Throws nv::Error unless an entry states its network's source grid (dims, association) and, on that grid, decodes
/// it sample for sample.
void CheckEntryAgainstNetwork(const VolumeFileEntry& entry, const nv::SourceInfo& source);
/// The bytes of a file (at most 4 GiB); throws nv::Error when it cannot be read.
std::vector<uint8_t> ReadFileBytes(const std::string& path);

} // namespace vtkNeuralCompressInternals

#endif
