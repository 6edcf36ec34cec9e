#include "vtkNeuralHdf5Layout.h"

#include "Core/Error.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>
#include <vector>

#if NV_HAVE_HDF5
#include "vtkNeuralHdf5Chunks.h"
#include "vtkNeuralHdf5Handle.h"

#include <cerrno>
#include <cstring>
#include <sys/stat.h>
#include <unistd.h>
#endif

namespace vtkNeuralCompressInternals
{
namespace
{
std::string LowerExtension(const std::string& path)
{
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    return std::string();
  std::string extension = path.substr(dot + 1);
  std::transform(extension.begin(), extension.end(), extension.begin(),
    [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

#if NV_HAVE_HDF5
/// The engine's type of an HDF5 type, or false for those the reader does not stream.
bool ScalarTypeOf(hid_t type, nv::ScalarType& scalar, bool& bigEndian)
{
  const H5T_class_t typeClass = H5Tget_class(type);
  const size_t size = H5Tget_size(type);
  bigEndian = H5Tget_order(type) == H5T_ORDER_BE;
  if (typeClass == H5T_FLOAT)
  {
    if (size != 4 && size != 8)
      return false;
    scalar = size == 4 ? nv::ScalarType::Float32 : nv::ScalarType::Float64;
    return true;
  }
  if (typeClass != H5T_INTEGER)
    return false;
  const bool isSigned = H5Tget_sign(type) == H5T_SGN_2;
  if (size == 1 && !isSigned)
    scalar = nv::ScalarType::UInt8;
  else if (size == 2)
    scalar = isSigned ? nv::ScalarType::Int16 : nv::ScalarType::UInt16;
  else if (size == 4 && isSigned)
    scalar = nv::ScalarType::Int32;
  else
    return false;
  return true;
}

/// Collects the names of the datasets of rank 3 (depth first).
herr_t CollectDataset(hid_t root, const char* name, const H5O_info_t* info, void* data)
{
  if (info->type != H5O_TYPE_DATASET)
    return 0;
  Hdf5Handle dataset(H5Dopen2(root, name, H5P_DEFAULT), H5Dclose);
  Hdf5Handle space(dataset.valid() ? H5Dget_space(dataset.get()) : -1, H5Sclose);
  if (space.valid() && H5Sget_simple_extent_ndims(space.get()) == 3)
    static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}

/// A 3-number attribute of the dataset (x first), when it has one.
bool Attribute3(hid_t dataset, const char* name, double values[3])
{
  if (H5Aexists(dataset, name) <= 0)
    return false;
  Hdf5Handle attribute(H5Aopen(dataset, name, H5P_DEFAULT), H5Aclose);
  Hdf5Handle space(attribute.valid() ? H5Aget_space(attribute.get()) : -1, H5Sclose);
  if (!space.valid() || H5Sget_simple_extent_npoints(space.get()) != 3)
    return false;
  return H5Aread(attribute.get(), H5T_NATIVE_DOUBLE, values) >= 0;
}

/// The dataset's storage: contiguous and unfiltered (a raw block of the file: no box source), or chunked (a box source
/// that decodes its chunks); throws with the reason otherwise.
std::shared_ptr<const nv::VolumeBoxSource> StreamableStorage(
  hid_t dataset, const std::string& path, const std::string& name, nv::ScalarType type, const std::string& where)
{
  Hdf5Handle plist(H5Dget_create_plist(dataset), H5Pclose);
  const H5D_layout_t layout = H5Pget_layout(plist.get());
  if (layout == H5D_CHUNKED)
    return OpenChunkedDataset(path, name, plist.get(), type, where);
  if (layout != H5D_CONTIGUOUS)
    NV_THROW(where + "the dataset is stored compact in the file's header: it cannot be streamed");
  if (H5Pget_nfilters(plist.get()) > 0)
    NV_THROW(where + "the dataset is filtered (compressed): it cannot be streamed; repack it without filters");
  return nullptr;
}

nv::VolumeFileLayout LayoutOfDataset(hid_t file, const std::string& path, const std::string& name)
{
  const std::string where = "'" + path + "', dataset '" + name + "': ";
  Hdf5Handle dataset(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dataset.valid())
    NV_THROW(where + "no such dataset");
  Hdf5Handle space(H5Dget_space(dataset.get()), H5Sclose);
  hsize_t dims[3] = { 0, 0, 0 };
  if (H5Sget_simple_extent_ndims(space.get()) != 3)
    NV_THROW(where + "the dataset is not 3-D");
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  nv::VolumeFileLayout layout;
  Hdf5Handle type(H5Dget_type(dataset.get()), H5Tclose);
  if (!ScalarTypeOf(type.get(), layout.type, layout.bigEndian))
    NV_THROW(where + "its sample type cannot be streamed (uint8, int16, uint16, int32, float32, float64 can)");
  layout.boxSource = StreamableStorage(dataset.get(), path, name, layout.type, where);
  const haddr_t offset = layout.boxSource ? 0 : H5Dget_offset(dataset.get());
  if (offset == HADDR_UNDEF)
    NV_THROW(where + "the dataset has no storage in the file (never written)");
  layout.headerPath = path;
  layout.dataPath = path;
  layout.dataOffset = static_cast<int64_t>(offset);
  for (int axis = 0; axis < 3; ++axis)
    layout.dims[axis] = static_cast<int64_t>(dims[2 - axis]); // HDF5: z slowest, x fastest
  Attribute3(dataset.get(), "spacing", layout.spacing);
  Attribute3(dataset.get(), "origin", layout.origin);
  for (int axis = 0; axis < 3; ++axis)
    if (!(layout.spacing[axis] > 0.0) || !std::isfinite(layout.spacing[axis]) || !std::isfinite(layout.origin[axis]))
      NV_THROW(where + "its 'spacing' or 'origin' attribute is not positive and finite");
  const size_t slash = name.find_last_of('/');
  layout.arrayName = slash == std::string::npos ? name : name.substr(slash + 1);
  layout.format = layout.boxSource ? "HDF5 (" + std::string(layout.boxSource->storage()) + ")"
                                    : std::string("HDF5 (contiguous dataset)");
  if (layout.boxSource)
    return layout; // its chunks may be compressed or not all written (HDF5 reads those as the fill value)
  const hsize_t stored = H5Dget_storage_size(dataset.get());
  if (static_cast<int64_t>(stored) < layout.bytes())
    NV_THROW(where + "the dataset stores " + std::to_string(stored) + " bytes but its extent needs " +
      std::to_string(layout.bytes()));
  return layout;
}
#endif
} // namespace

bool IsHdf5Path(const std::string& path)
{
  const std::string extension = LowerExtension(path);
  return extension == "h5" || extension == "hdf5";
}

nv::VolumeFileLayout ReadHdf5Layout(const std::string& path, const std::string& datasetPath)
{
#if NV_HAVE_HDF5
  Hdf5Section section; // one HDF5 call at a time; errors are reported as nv::Error, not printed by HDF5
  if (::access(path.c_str(), R_OK) != 0)
    NV_THROW("'" + path + "': cannot be read: " + std::strerror(errno));
  if (H5Fis_hdf5(path.c_str()) <= 0)
    NV_THROW("'" + path + "': not an HDF5 file");
  Hdf5Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid())
    NV_THROW("'" + path + "': the HDF5 file cannot be opened (" + Hdf5LastError() + ")");
  std::string name = datasetPath;
  if (name.empty())
  {
    std::vector<std::string> candidates;
    H5Ovisit2(file.get(), H5_INDEX_NAME, H5_ITER_INC, CollectDataset, &candidates, H5O_INFO_BASIC);
    if (candidates.empty())
      NV_THROW("'" + path + "': the file holds no 3-D dataset");
    name = candidates.front();
  }
  nv::VolumeFileLayout layout = LayoutOfDataset(file.get(), path, name);
  struct stat info;
  const bool raw = !layout.boxSource; // a chunked dataset's bytes may be compressed or unwritten
  if (raw && (::stat(path.c_str(), &info) != 0 || int64_t(info.st_size) - layout.dataOffset < layout.bytes()))
    NV_THROW("'" + path + "', dataset '" + name + "': the dataset's " + std::to_string(layout.bytes()) +
      " bytes from byte " + std::to_string(layout.dataOffset) + " run past the end of the file (" +
      std::to_string(int64_t(info.st_size)) + " bytes): the file is truncated");
  return layout;
#else
  (void)datasetPath;
  NV_THROW("'" + path + "': this build of the NeuralVolume plugin has no HDF5 (the HDF5 development files were not "
    "found when it was built)");
#endif
}

nv::VolumeFileLayout ReadOutOfCoreLayout(const std::string& path, const std::string& arrayName)
{
  return IsHdf5Path(path) ? ReadHdf5Layout(path, arrayName) : nv::readVolumeFileLayout(path, arrayName);
}

} // namespace vtkNeuralCompressInternals
