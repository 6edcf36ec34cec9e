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

/// How reads use the page cache. A machine whose memory holds the file reads it from the cache after the first pass;
/// the two bypasses read the disk itself, as a machine whose memory cannot hold the file does.
enum class PageCacheUse : int
{
  Normal = 0,    ///< pread through the page cache
  Bypass = 1,    ///< O_DIRECT: each read widened to whole 4 KiB pages into an aligned buffer (falls back to DropBehind
                 ///< where the file system refuses O_DIRECT)
  DropBehind = 2 ///< pread, then posix_fadvise(DONTNEED) on the pages read
};

class VolumeFileReader
{
public:
  /// Opens layout.dataPath (throws nv::Error with the reason).
  explicit VolumeFileReader(const VolumeFileLayout& layout, PageCacheUse cache = PageCacheUse::Normal);
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
  /// Bytes the reads took from the file (Bypass: whole pages; else as bytesRead).
  int64_t bytesTransferred() const { return BytesTransferred.load(); }
  /// Reads (pread calls) so far, all threads.
  int64_t readCalls() const { return ReadCalls.load(); }
  /// The page-cache use in effect (Bypass asked on a file system without O_DIRECT: DropBehind).
  PageCacheUse pageCache() const { return Cache; }
  /// A box's rows of one z-slice whose span in the file is at most this many bytes are read with one read of that
  /// span (through the page cache and with Bypass; DropBehind reads a row at a time, dropping only what it read):
  /// a 128 x 2 x 2-cell brick of a 1280-wide float32 file (3 rows 5120 bytes apart) is 3 reads instead of 9; 32 KiB
  /// covers such bricks up to a 4000-wide float32 file. Measured with spans of 10.5 KiB (nvDiskRandomRead, 2-core
  /// VM): with O_DIRECT 2.1x the bricks a second at 4 threads, 1.8x at 16 (a disk serves a
  /// read of a few pages in about the time of one); from the page cache 1.2-1.4x (fewer calls for more bytes copied).
  static constexpr int64_t kSliceSpanBytes = 32768;

private:
  template <typename Out>
  void readBoxAs(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, Out* out) const;
  /// Reads `count` bytes at `position`; `useful` of them count as read (bytesRead), all as transferred.
  void readBytes(int64_t position, int64_t count, unsigned char* into, int64_t useful) const;

  void readDirect(int64_t position, int64_t count, unsigned char* into) const;

  VolumeFileLayout Layout;
  PageCacheUse Cache = PageCacheUse::Normal;
  int FileDescriptor = -1;
  int DirectDescriptor = -1; ///< the same file opened with O_DIRECT (Bypass)
  mutable std::atomic<int64_t> BytesRead{ 0 };
  mutable std::atomic<int64_t> BytesTransferred{ 0 };
  mutable std::atomic<int64_t> ReadCalls{ 0 };
};

} // namespace nv
