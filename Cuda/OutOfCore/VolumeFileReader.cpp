// NeuralVolume engine, out-of-core training: boxes of samples read from a volume file with pread (VolumeFileReader.h).
#include "VolumeFileReader.h"

#include "VolumeBoxSource.h"

#include "Core/Error.h"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <limits>
#include <string>
#include <unistd.h>
#include <vector>

namespace nv
{
namespace
{
/// A row of `count` raw samples of type Stored (byte-swapped when `swap`) as Out values.
template <typename Stored, typename Out>
void convertRowAs(const unsigned char* row, int64_t count, bool swap, Out* out)
{
  for (int64_t i = 0; i < count; ++i)
  {
    unsigned char bytes[sizeof(Stored)];
    std::memcpy(bytes, row + i * static_cast<int64_t>(sizeof(Stored)), sizeof(Stored));
    if (swap)
      std::reverse(bytes, bytes + sizeof(Stored));
    Stored value;
    std::memcpy(&value, bytes, sizeof(Stored));
    out[i] = static_cast<Out>(value);
  }
}

/// The file's type chosen once per row (the readers' hot loop converts without a branch per sample).
template <typename Out>
void convertRow(const unsigned char* row, int64_t count, ScalarType type, bool swap, Out* out)
{
  switch (type)
  {
    case ScalarType::UInt8:
      return convertRowAs<uint8_t>(row, count, swap, out);
    case ScalarType::Int16:
      return convertRowAs<int16_t>(row, count, swap, out);
    case ScalarType::UInt16:
      return convertRowAs<uint16_t>(row, count, swap, out);
    case ScalarType::Int32:
      return convertRowAs<int32_t>(row, count, swap, out);
    case ScalarType::Float32:
      return convertRowAs<float>(row, count, swap, out);
    case ScalarType::Float64:
      return convertRowAs<double>(row, count, swap, out);
    default:
      NV_THROW(std::string("a volume file of ") + scalarTypeName(type) + " samples cannot be read");
  }
}

bool hostIsBigEndian()
{
  const uint16_t probe = 1;
  unsigned char first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 0;
}
} // namespace

FileReadTally::FileReadTally()
{
  for (int axis = 0; axis < 3; ++axis)
  {
    this->Lo[axis] = std::numeric_limits<int64_t>::max();
    this->Hi[axis] = -1;
  }
}

void FileReadTally::add(const std::array<int64_t, 3>& fileOrigin, const std::array<int64_t, 3>& size, int64_t bytes)
{
  this->Bytes += bytes;
  for (int axis = 0; axis < 3; ++axis)
  {
    const int64_t lo = fileOrigin[axis], hi = fileOrigin[axis] + size[axis] - 1;
    int64_t seen = this->Lo[axis].load();
    while (lo < seen && !this->Lo[axis].compare_exchange_weak(seen, lo))
    {
    }
    seen = this->Hi[axis].load();
    while (hi > seen && !this->Hi[axis].compare_exchange_weak(seen, hi))
    {
    }
  }
}

bool FileReadTally::box(int64_t lo[3], int64_t hi[3]) const
{
  for (int axis = 0; axis < 3; ++axis)
  {
    lo[axis] = this->Lo[axis].load();
    hi[axis] = this->Hi[axis].load();
  }
  return hi[0] >= lo[0] && hi[1] >= lo[1] && hi[2] >= lo[2];
}

VolumeFileLayout volumeFileSubBox(const VolumeFileLayout& layout, const int64_t origin[3], const int64_t size[3])
{
  VolumeFileLayout box = layout;
  for (int axis = 0; axis < 3; ++axis)
  {
    NV_CHECK(origin[axis] >= 0 && size[axis] >= 1 && origin[axis] + size[axis] <= layout.dims[axis],
      "a sub-box must lie inside the volume file's samples");
    box.fileDims[axis] = layout.fileDim(axis);
    box.boxOrigin[axis] = layout.boxOrigin[axis] + origin[axis];
    box.dims[axis] = size[axis];
  }
  return box;
}

VolumeFileReader::VolumeFileReader(const VolumeFileLayout& layout, PageCacheUse cache)
  : Layout(layout)
  , Cache(layout.boxSource ? PageCacheUse::Normal : cache) // a chunked source reads through its library
{
  this->FileDescriptor = ::open(layout.dataPath.c_str(), O_RDONLY | O_CLOEXEC);
  if (this->FileDescriptor < 0)
    NV_THROW("cannot open '" + layout.dataPath + "': " + std::strerror(errno));
  if (this->Cache == PageCacheUse::Bypass)
  {
    this->DirectDescriptor = ::open(layout.dataPath.c_str(), O_RDONLY | O_CLOEXEC | O_DIRECT);
    if (this->DirectDescriptor < 0)
      this->Cache = PageCacheUse::DropBehind; // tmpfs and some others refuse O_DIRECT
  }
  if (this->Cache != PageCacheUse::Normal)
    ::posix_fadvise(this->FileDescriptor, 0, 0, POSIX_FADV_RANDOM); // no read-ahead of pages nobody asked for
}

VolumeFileReader::~VolumeFileReader()
{
  if (this->FileDescriptor >= 0)
    ::close(this->FileDescriptor);
  if (this->DirectDescriptor >= 0)
    ::close(this->DirectDescriptor);
}

void VolumeFileReader::readDirect(int64_t position, int64_t count, unsigned char* into) const
{
  // O_DIRECT reads whole pages into page-aligned memory: the span of pages around the bytes asked, a thread's buffer
  // kept between calls (at most kRunBytes plus two pages: readBoxAs never asks for more at once).
  constexpr int64_t kPage = 4096;
  struct AlignedBuffer
  {
    unsigned char* data = nullptr;
    int64_t size = 0;
    ~AlignedBuffer() { std::free(this->data); }
  };
  thread_local AlignedBuffer buffer;
  const int64_t first = position / kPage * kPage;
  const int64_t span = (position + count + kPage - 1) / kPage * kPage - first;
  if (buffer.size < span)
  {
    std::free(buffer.data);
    buffer.data = static_cast<unsigned char*>(std::aligned_alloc(kPage, static_cast<size_t>(span)));
    buffer.size = buffer.data ? span : 0;
    NV_CHECK(buffer.data != nullptr, "cannot allocate a read buffer of " + std::to_string(span) + " bytes");
  }
  const int64_t needed = position + count - first; // the last page may be the file's partial last page
  int64_t done = 0;
  while (done < needed)
  {
    const ssize_t got = ::pread(this->DirectDescriptor, buffer.data + done, static_cast<size_t>(span - done),
      static_cast<off_t>(first + done));
    if (got < 0 && errno == EINTR)
      continue;
    if (got <= 0)
      NV_THROW("reading '" + this->Layout.dataPath + "' at byte " + std::to_string(first + done) + " (O_DIRECT) failed: " +
        (got < 0 ? std::string(std::strerror(errno)) : std::string("the file ends there (it shrank)")));
    done += got;
  }
  std::memcpy(into, buffer.data + (position - first), static_cast<size_t>(count));
  this->BytesTransferred += done;
}

int64_t VolumeFileReader::bytesRead() const
{
  return this->BytesRead.load();
}

void VolumeFileReader::readBytes(int64_t position, int64_t count, unsigned char* into, int64_t useful) const
{
  ++this->ReadCalls;
  if (this->Cache == PageCacheUse::Bypass)
  {
    this->readDirect(position, count, into);
    this->BytesRead += useful;
    return;
  }
  int64_t done = 0;
  while (done < count)
  {
    const ssize_t got = ::pread(this->FileDescriptor, into + done, static_cast<size_t>(count - done),
      static_cast<off_t>(position + done));
    if (got < 0 && errno == EINTR)
      continue;
    if (got <= 0)
      NV_THROW("reading '" + this->Layout.dataPath + "' at byte " + std::to_string(position + done) + " failed: " +
        (got < 0 ? std::string(std::strerror(errno)) : std::string("the file ends there (it shrank)")));
    done += got;
  }
  if (this->Cache == PageCacheUse::DropBehind)
    ::posix_fadvise(this->FileDescriptor, static_cast<off_t>(position), static_cast<off_t>(count), POSIX_FADV_DONTNEED);
  this->BytesRead += useful;
  this->BytesTransferred += count;
}

template <typename Out>
void VolumeFileReader::readBoxAs(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, Out* out) const
{
  for (int axis = 0; axis < 3; ++axis)
    NV_CHECK(origin[axis] >= 0 && size[axis] >= 1 && origin[axis] + size[axis] <= this->Layout.dims[axis],
      "the box must lie inside the volume");
  const int64_t bytes = static_cast<int64_t>(scalarSize(this->Layout.type));
  // The box in the file's own samples (a sub-box layout reads only within its box).
  const std::array<int64_t, 3> at = { origin[0] + this->Layout.boxOrigin[0], origin[1] + this->Layout.boxOrigin[1],
    origin[2] + this->Layout.boxOrigin[2] };
  if (this->Layout.readTally)
    this->Layout.readTally->add(at, size, size[0] * size[1] * size[2] * bytes);
  if (this->Layout.boxSource)
  {
    this->Layout.boxSource->readBox(at, size, out); // chunks decoded by the source
    this->BytesRead += size[0] * size[1] * size[2] * bytes;
    return;
  }
  const bool swap = bytes > 1 && this->Layout.bigEndian != hostIsBigEndian();
  const int64_t nx = this->Layout.fileDim(0), ny = this->Layout.fileDim(1);
  // Whole rows are contiguous across y: one read a run of rows (up to kRunBytes, held per call: a pass's threads hold
  // at most 16 MiB), not one a row (a streamed pass of a 2176^2-sample float32 plane: 19 reads, not 2176).
  constexpr int64_t kRunBytes = int64_t(1) << 20;
  const int64_t rowsPerRun = size[0] == nx ? std::max<int64_t>(1, std::min(size[1], kRunBytes / (nx * bytes))) : 1;
  // Rows of part of the width: a slice's rows in one read when they lie close (kSliceSpanBytes).
  const int64_t sliceSpan = ((size[1] - 1) * nx + size[0]) * bytes;
  const bool slices = rowsPerRun == 1 && size[1] > 1 && this->Cache != PageCacheUse::DropBehind &&
    sliceSpan <= kSliceSpanBytes;
  std::vector<unsigned char> run(static_cast<size_t>(slices ? sliceSpan : rowsPerRun * size[0] * bytes));
  for (int64_t z = 0; z < size[2]; ++z)
  {
    if (slices)
    {
      const int64_t first = ((at[2] + z) * ny + at[1]) * nx + at[0];
      this->readBytes(this->Layout.dataOffset + first * bytes, sliceSpan, run.data(), size[0] * size[1] * bytes);
      for (int64_t y = 0; y < size[1]; ++y)
        convertRow(run.data() + y * nx * bytes, size[0], this->Layout.type, swap, out + (z * size[1] + y) * size[0]);
      continue;
    }
    for (int64_t y = 0; y < size[1]; y += rowsPerRun)
    {
      const int64_t rows = std::min(rowsPerRun, size[1] - y);
      const int64_t first = ((at[2] + z) * ny + at[1] + y) * nx + at[0];
      const int64_t count = rows * size[0] * bytes;
      this->readBytes(this->Layout.dataOffset + first * bytes, count, run.data(), count);
      convertRow(run.data(), rows * size[0], this->Layout.type, swap, out + (z * size[1] + y) * size[0]);
    }
  }
}

void VolumeFileReader::readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, float* out) const
{
  this->readBoxAs(origin, size, out);
}

void VolumeFileReader::readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, double* out) const
{
  this->readBoxAs(origin, size, out);
}

} // namespace nv
