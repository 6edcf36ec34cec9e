// Private to NeuralVolume::Filters (NV_HAVE_HDF5 builds): a chunked HDF5 dataset streamed box by box. Each box the
// engine asks for (a block of the block buffer, a slab of a streamed pass) is one hyperslab read through the HDF5
// library, which decodes the chunks it touches (deflate, shuffle, ... whatever filters that library has); a small
// chunk cache (kCachedChunks chunks) is the only memory besides the box. Filters the library cannot decode are refused
// when the dataset is opened.
#ifndef vtkNeuralHdf5Chunks_h
#define vtkNeuralHdf5Chunks_h

#include "Core/Volume.h"
#include "OutOfCore/VolumeBoxSource.h"

#include <hdf5.h>

#include <memory>
#include <string>

namespace vtkNeuralCompressInternals
{

/// Chunks HDF5 may keep decoded between reads (a box crossing chunk borders reads its neighbours again otherwise).
constexpr int kCachedChunks = 4;

/// The box source of the chunked dataset `name` of `path`, whose creation property list is `createPlist` and sample
/// type `type`. Throws nv::Error (prefixed by `where`) when a filter of the dataset cannot be decoded here or its
/// chunks are not 3-D. Call with the plugin's HDF5 lock held (vtkNeuralHdf5Handle.h).
std::shared_ptr<const nv::VolumeBoxSource> OpenChunkedDataset(
  const std::string& path, const std::string& name, hid_t createPlist, nv::ScalarType type, const std::string& where);

} // namespace vtkNeuralCompressInternals

#endif
