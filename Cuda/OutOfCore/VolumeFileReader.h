// NeuralVolume engine, out-of-core training: reads boxes of samples from a volume file (VolumeFileLayout.h) with
// pread, converting its type and byte order. The file stays on disk; one reader serves many threads at once (pread
// keeps no shared file position).
//
//   nv::VolumeFileReader reader(nv::readVolumeFileLayout("ct.nhdr"));
//   std::vector<float> brick(32 * 32 * 32);
//   reader.readBox({ 64, 0, 96 }, { 32, 32, 32 }, brick.data());   // x fastest
#pragma once

#include "VolumeFileLayout.h"

#include <array>
#include <atomic>
#include <cstdint>

namespace nv
{

/// What the readers of one layout read (VolumeFileLayout::readTally), from any thread: the bytes, and the bounding box
/// of every sample read, in the file's own sample indices.
class FileReadTally
{
public:
  FileReadTally();
  void add(const std::array<int64_t, 3>& fileOrigin, const std::array<int64_t, 3>& size, int64_t bytes);
  int64_t bytes() const { return this->Bytes.load(); }
  /// The box read (inclusive lo..hi per axis); false while nothing was read.
  bool box(int64_t lo[3], int64_t hi[3]) const;

private:
  std::atomic<int64_t> Bytes{ 0 };
  std::atomic<int64_t> Lo[3];
  std::atomic<int64_t> Hi[3];
};

class VolumeFileReader
{
public:
  /// Opens layout.dataPath (throws nv::Error with the reason).
  explicit VolumeFileReader(const VolumeFileLayout& layout);
  ~VolumeFileReader();
  VolumeFileReader(const VolumeFileReader&) = delete;
  VolumeFileReader& operator=(const VolumeFileReader&) = delete;

  const VolumeFileLayout& layout() const { return Layout; }
  /// The samples of the box at `origin` (sample indices) of `size` samples per axis, in the file's units, x fastest;
  /// the box must lie inside the volume (the layout's sub-box, if it is one: indices relative to it). Throws nv::Error when the file cannot be read (it shrank, an I/O error).
  void readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, float* out) const;
  void readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, double* out) const;
  /// Bytes read from the file so far (all threads).
  int64_t bytesRead() const;

private:
  template <typename Out>
  void readBoxAs(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, Out* out) const;
  void readBytes(int64_t position, int64_t count, unsigned char* into) const;

  VolumeFileLayout Layout;
  int FileDescriptor = -1;
  mutable std::atomic<int64_t> BytesRead{ 0 };
};

} // namespace nv
