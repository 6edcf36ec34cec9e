// NeuralVolume engine, out-of-core training: a decoder of boxes of samples for a volume file whose samples are not one
// raw block (an HDF5 dataset stored in chunks, possibly compressed: the plugin decodes its chunks with the HDF5
// library). A VolumeFileLayout that carries one (VolumeFileLayout::boxSource) is read through it by VolumeFileReader
// instead of pread; the engine itself stays free of any file library.
#pragma once

#include <array>
#include <cstdint>

namespace nv
{

class VolumeBoxSource
{
public:
  virtual ~VolumeBoxSource() = default;
  /// The samples of the box at `origin` (sample indices, x first) of `size` samples per axis in the file's units,
  /// x fastest. Called from several threads at once (the implementation serialises what it must). Throws nv::Error.
  virtual void readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, float* out) const = 0;
  virtual void readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, double* out) const = 0;
  /// Bytes a read may hold besides its box (decoded chunks, their cache): counted against the memory budget.
  virtual int64_t workingBytes() const = 0;
  /// The storage, for messages ("chunks of 64 x 64 x 64, deflate").
  virtual const char* storage() const = 0;
};

} // namespace nv
