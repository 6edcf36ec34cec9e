#include "vtkNeuralHdf5Layout.h"

#include "Core/Error.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>
#include <vector>

#if NV_HAVE_HDF5
#include <hdf5.h>
#include <sys/stat.h>
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
/// Closes an HDF5 identifier when it goes out of scope.
class Handle
{
public:
  Handle(hid_t id, herr_t (*close)(hid_t))
    : Id(id)
    , Close(close)
  {
  }
  ~Handle()
  {
    if (this->Id >= 0)
      this->Close(this->Id);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return this->Id; }
  bool valid() const { return this->Id >= 0; }

private:
  hid_t Id;
  herr_t (*Close)(hid_t);
};

/// HDF5's automatic error printing off while it lives (the caller reports the reason), restored after.
class SilentErrors
{
public:
  SilentErrors()
  {
    H5Eget_auto2(H5E_DEFAULT, &this->Function, &this->Data);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~SilentErrors() { H5Eset_auto2(H5E_DEFAULT, this->Function, this->Data); }
  SilentErrors(const SilentErrors&) = delete;
  SilentErrors& operator=(const SilentErrors&) = delete;

private:
  H5E_auto2_t Function = nullptr;
  void* Data = nullptr;
};

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
  Handle dataset(H5Dopen2(root, name, H5P_DEFAULT), H5Dclose);
  Handle space(dataset.valid() ? H5Dget_space(dataset.get()) : -1, H5Sclose);
  if (space.valid() && H5Sget_simple_extent_ndims(space.get()) == 3)
    static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}

/// A 3-number attribute of the dataset (x first), when it has one.
bool Attribute3(hid_t dataset, const char* name, double values[3])
{
  if (H5Aexists(dataset, name) <= 0)
    return false;
  Handle attribute(H5Aopen(dataset, name, H5P_DEFAULT), H5Aclose);
  Handle space(attribute.valid() ? H5Aget_space(attribute.get()) : -1, H5Sclose);
  if (!space.valid() || H5Sget_simple_extent_npoints(space.get()) != 3)
    return false;
  return H5Aread(attribute.get(), H5T_NATIVE_DOUBLE, values) >= 0;
}

/// The dataset's storage: contiguous, unfiltered, allocated; throws with the reason otherwise.
void CheckStreamable(hid_t dataset, const std::string& where)
{
  Handle plist(H5Dget_create_plist(dataset), H5Pclose);
  const H5D_layout_t layout = H5Pget_layout(plist.get());
  if (layout == H5D_CHUNKED)
  {
    hsize_t chunk[3] = { 0, 0, 0 };
    H5Pget_chunk(plist.get(), 3, chunk);
    NV_THROW(where + "the dataset is chunked (chunks of " + std::to_string(chunk[2]) + " x " +
      std::to_string(chunk[1]) + " x " + std::to_string(chunk[0]) + "): a chunked layout cannot be streamed yet; "
      "repack it contiguous (h5repack -l CONTI)");
  }
  if (layout != H5D_CONTIGUOUS)
    NV_THROW(where + "the dataset is stored compact in the file's header: it cannot be streamed");
  if (H5Pget_nfilters(plist.get()) > 0)
    NV_THROW(where + "the dataset is filtered (compressed): it cannot be streamed; repack it without filters");
}

nv::VolumeFileLayout LayoutOfDataset(hid_t file, const std::string& path, const std::string& name)
{
  const std::string where = "'" + path + "', dataset '" + name + "': ";
  Handle dataset(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dataset.valid())
    NV_THROW(where + "no such dataset");
  Handle space(H5Dget_space(dataset.get()), H5Sclose);
  hsize_t dims[3] = { 0, 0, 0 };
  if (H5Sget_simple_extent_ndims(space.get()) != 3)
    NV_THROW(where + "the dataset is not 3-D");
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  nv::VolumeFileLayout layout;
  Handle type(H5Dget_type(dataset.get()), H5Tclose);
  if (!ScalarTypeOf(type.get(), layout.type, layout.bigEndian))
    NV_THROW(where + "its sample type cannot be streamed (uint8, int16, uint16, int32, float32, float64 can)");
  CheckStreamable(dataset.get(), where);
  const haddr_t offset = H5Dget_offset(dataset.get());
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
  layout.format = "HDF5 (contiguous dataset)";
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
  SilentErrors silent; // errors are reported as nv::Error, not printed by HDF5
  if (H5Fis_hdf5(path.c_str()) <= 0)
    NV_THROW("'" + path + "': not an HDF5 file (or it cannot be read)");
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid())
    NV_THROW("'" + path + "': cannot open the HDF5 file");
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
  if (::stat(path.c_str(), &info) != 0 || int64_t(info.st_size) - layout.dataOffset < layout.bytes())
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
