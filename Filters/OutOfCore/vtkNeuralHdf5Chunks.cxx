// The chunked HDF5 dataset as a box source (vtkNeuralHdf5Chunks.h) and the plugin's HDF5 lock (vtkNeuralHdf5Handle.h).
#if NV_HAVE_HDF5
#include "vtkNeuralHdf5Chunks.h"

#include "vtkNeuralHdf5Handle.h"

#include "Core/Error.h"

#include <array>
#include <sstream>
#include <vector>

namespace vtkNeuralCompressInternals
{

std::recursive_mutex& Hdf5Mutex()
{
  static std::recursive_mutex mutex;
  return mutex;
}

Hdf5Section::Hdf5Section()
  : Lock(Hdf5Mutex())
{
  H5Eget_auto2(H5E_DEFAULT, &this->Function, &this->Data);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

Hdf5Section::~Hdf5Section()
{
  H5Eset_auto2(H5E_DEFAULT, this->Function, this->Data);
}

std::string Hdf5LastError()
{
  std::string message;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD,
    [](unsigned depth, const H5E_error2_t* error, void* data) -> herr_t {
      if (depth == 0 && error->desc)
        *static_cast<std::string*>(data) = error->desc;
      return 0;
    },
    &message);
  return message;
}

namespace
{
/// The filters of a chunked dataset, each checked: decodable by this HDF5 library, or nv::Error naming it.
std::string CheckFilters(hid_t createPlist, const std::string& where)
{
  std::ostringstream names;
  const int count = H5Pget_nfilters(createPlist);
  for (int k = 0; k < count; ++k)
  {
    unsigned flags = 0, configuration = 0;
    size_t values = 0;
    char name[64] = { 0 };
    const H5Z_filter_t filter = H5Pget_filter2(createPlist, unsigned(k), &flags, &values, nullptr, sizeof(name), name,
      &configuration);
    unsigned decoding = 0;
    const bool available = filter >= 0 && H5Zfilter_avail(filter) > 0 &&
      H5Zget_filter_info(filter, &decoding) >= 0 && (decoding & H5Z_FILTER_CONFIG_DECODE_ENABLED);
    if (!available)
      NV_THROW(where + "the dataset's chunks are encoded with the filter '" + std::string(name) + "' (HDF5 filter " +
        std::to_string(int(filter)) + "), which the HDF5 library ParaView uses cannot decode: a chunk layout that "
        "cannot be streamed; repack it with a standard filter or none (h5repack -f GZIP=4, or -f NONE)");
    names << (k ? ", " : "") << (name[0] ? name : "filter " + std::to_string(int(filter)));
  }
  return names.str();
}

class ChunkedDataset final : public nv::VolumeBoxSource
{
public:
  ChunkedDataset(const std::string& path, const std::string& name, int64_t chunkBytes, const std::string& storage)
    : ChunkBytes(chunkBytes)
    , Storage(storage)
    , Path(path)
  {
    Hdf5Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    Hdf5Handle access(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
    // A prime number of slots well above the cached chunks; w0 1: fully read chunks are evicted first.
    H5Pset_chunk_cache(access.get(), 521, size_t(chunkBytes) * kCachedChunks, 1.0);
    Hdf5Handle dataset(file.valid() ? H5Dopen2(file.get(), name.c_str(), access.get()) : -1, H5Dclose);
    if (!dataset.valid())
      NV_THROW("'" + path + "', dataset '" + name + "': cannot be opened for reading (" + Hdf5LastError() + ")");
    this->File = file.release();
    this->Dataset = dataset.release();
  }
  ~ChunkedDataset() override
  {
    std::lock_guard<std::recursive_mutex> lock(Hdf5Mutex());
    H5Dclose(this->Dataset);
    H5Fclose(this->File);
  }
  void readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, float* out) const override
  {
    this->read(origin, size, H5T_NATIVE_FLOAT, out);
  }
  void readBox(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, double* out) const override
  {
    this->read(origin, size, H5T_NATIVE_DOUBLE, out);
  }
  /// The cache, a chunk decoded outside it and its encoded bytes.
  int64_t workingBytes() const override { return this->ChunkBytes * (kCachedChunks + 2); }
  const char* storage() const override { return this->Storage.c_str(); }

private:
  void read(const std::array<int64_t, 3>& origin, const std::array<int64_t, 3>& size, hid_t memoryType, void* out) const
  {
    Hdf5Section section;
    // HDF5 orders the axes z, y, x (x fastest), as the box is laid out.
    const hsize_t start[3] = { hsize_t(origin[2]), hsize_t(origin[1]), hsize_t(origin[0]) };
    const hsize_t count[3] = { hsize_t(size[2]), hsize_t(size[1]), hsize_t(size[0]) };
    Hdf5Handle fileSpace(H5Dget_space(this->Dataset), H5Sclose);
    Hdf5Handle memorySpace(H5Screate_simple(3, count, nullptr), H5Sclose);
    const bool selected = fileSpace.valid() && memorySpace.valid() &&
      H5Sselect_hyperslab(fileSpace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) >= 0;
    if (!selected || H5Dread(this->Dataset, memoryType, memorySpace.get(), fileSpace.get(), H5P_DEFAULT, out) < 0)
      NV_THROW("reading '" + this->Path + "' (samples " + std::to_string(origin[0]) + ", " +
        std::to_string(origin[1]) + ", " + std::to_string(origin[2]) + ", " + this->Storage + ") failed: " +
        Hdf5LastError());
  }

  hid_t File = -1;
  hid_t Dataset = -1;
  int64_t ChunkBytes;
  std::string Storage;
  std::string Path;
};
} // namespace

std::shared_ptr<const nv::VolumeBoxSource> OpenChunkedDataset(
  const std::string& path, const std::string& name, hid_t createPlist, nv::ScalarType type, const std::string& where)
{
  hsize_t chunk[3] = { 0, 0, 0 };
  if (H5Pget_chunk(createPlist, 3, chunk) != 3)
    NV_THROW(where + "the dataset's chunks are not 3-D");
  const std::string filters = CheckFilters(createPlist, where);
  const int64_t chunkBytes = int64_t(chunk[0]) * int64_t(chunk[1]) * int64_t(chunk[2]) * int64_t(nv::scalarSize(type));
  std::ostringstream storage;
  storage << "chunks of " << chunk[2] << " x " << chunk[1] << " x " << chunk[0]
          << (filters.empty() ? std::string(", no filter") : ", " + filters);
  return std::make_shared<ChunkedDataset>(path, name, chunkBytes, storage.str());
}

} // namespace vtkNeuralCompressInternals

#endif // NV_HAVE_HDF5
