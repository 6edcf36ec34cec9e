// NeuralVolume engine, out-of-core training (issue 22): where a volume's samples lie in a file, read from its header
// alone -- the file's samples are never loaded whole. Formats (each header checked against the data file's size):
//   .nhdr  NRRD with a detached header ("data file:" beside it), raw encoding
//   .nrrd  NRRD with the raw samples after the header's blank line
//   .bov   Brick of Values (DATA_FILE, DATA_SIZE, DATA_FORMAT, DATA_ENDIAN, BRICK_ORIGIN, BRICK_SIZE, CENTERING,
//          BYTE_OFFSET, DATA_COMPONENTS 1)
//   .vti   VTK XML image data whose point array is appended raw (no compressor, no base64)
// Sample types: uint8, int16, uint16, int32, float32, float64, little or big endian; x fastest, then y, then z.
//
//   nv::VolumeFileLayout layout = nv::readVolumeFileLayout("ct.nhdr");   // throws nv::Error with the reason
//   nv::VolumeFileReader reader(layout);                                   // VolumeFileReader.h: reads bricks
#pragma once

#include "Core/Volume.h"

#include <cstdint>
#include <memory>
#include <string>

namespace nv
{
class VolumeBoxSource;
class FileReadTally;

struct VolumeFileLayout
{
  std::string headerPath;  ///< the file the user named
  std::string dataPath;    ///< the file that holds the samples (the header's own file for .nrrd and .vti)
  int64_t dataOffset = 0;  ///< byte of the first sample in dataPath
  int64_t dims[3] = { 0, 0, 0 };
  ScalarType type = ScalarType::Float32; ///< one of uint8, int16, uint16, int32, float32, float64
  bool bigEndian = false;
  double origin[3] = { 0.0, 0.0, 0.0 };
  double spacing[3] = { 1.0, 1.0, 1.0 };
  std::string arrayName;   ///< the field's name (the header's, else the file's stem)
  std::string format;      ///< "NRRD (detached header)", "NRRD", "BOV", "VTK XML image data"
  /// Decodes boxes where the samples are not one raw block at dataOffset (VolumeBoxSource.h: an HDF5 chunked
  /// dataset); null for the raw layouts, which VolumeFileReader reads with pread.
  std::shared_ptr<const VolumeBoxSource> boxSource;
  /// A sub-box of the file (volumeFileSubBox): `dims` samples from sample `boxOrigin` of the file's `fileDims`; every
  /// reader of this layout reads only them, sample (0,0,0) being the file's boxOrigin. origin and spacing stay the
  /// file's (sample i of the box lies at origin + (boxOrigin + i) * spacing). The whole file: boxOrigin 0, fileDims 0.
  int64_t boxOrigin[3] = { 0, 0, 0 };
  int64_t fileDims[3] = { 0, 0, 0 };
  /// Optional: every reader made from (a copy of) this layout adds its reads to it (VolumeFileReader.h).
  std::shared_ptr<FileReadTally> readTally;

  int64_t samples() const { return dims[0] * dims[1] * dims[2]; }
  int64_t bytes() const { return samples() * static_cast<int64_t>(scalarSize(type)); }
  /// Samples of the file itself along `axis` (dims[axis] unless this is a sub-box).
  int64_t fileDim(int axis) const { return fileDims[axis] > 0 ? fileDims[axis] : dims[axis]; }
  int64_t fileBytes() const
  {
    return fileDim(0) * fileDim(1) * fileDim(2) * static_cast<int64_t>(scalarSize(type));
  }
};

/// Reads the header of `path` (by its extension: .nhdr, .nrrd, .bov, .vti) and checks it: three positive sizes whose
/// product fits, a supported type and encoding, positive finite spacing, and a data file that holds every byte the
/// header promises (the message names both figures when it does not). `arrayName`: the .vti point array to use (empty:
/// the active scalars, else the first single-component array). Throws nv::Error.
VolumeFileLayout readVolumeFileLayout(const std::string& path, const std::string& arrayName = std::string());

/// The box of `layout` at `origin` (sample indices of `layout`) of `size` samples per axis, which must lie inside it:
/// a layout whose readers, block buffers and passes see only that box (one rank's piece of the file under MPI).
/// Throws nv::Error.
VolumeFileLayout volumeFileSubBox(const VolumeFileLayout& layout, const int64_t origin[3], const int64_t size[3]);

} // namespace nv
