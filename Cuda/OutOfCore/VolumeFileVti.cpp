// NeuralVolume engine, out-of-core training: a VTK XML image data file (.vti) whose point array is appended raw
// (the XML writer's default without compression): its XML head gives the extent, origin and spacing and the array's
// offset into the appended block, where a byte count (UInt32 or UInt64, header_type) precedes the samples.
#include "Core/Error.h"
#include "VolumeFileLayout.h"
#include "VolumeFileText.h"

#include <cmath>
#include <fstream>
#include <vector>

namespace nv
{
namespace
{
using namespace volumefiletext;

/// The value of attribute `name` in the XML tag `tag` ("" when absent).
std::string attribute(const std::string& tag, const std::string& name)
{
  const std::string key = " " + name + "=\"";
  const size_t start = tag.find(key);
  if (start == std::string::npos)
    return std::string();
  const size_t valueStart = start + key.size();
  const size_t end = tag.find('"', valueStart);
  return end == std::string::npos ? std::string() : tag.substr(valueStart, end - valueStart);
}

/// The tag that starts at the first "<name" at or after `from` (up to its '>'); npos-safe.
std::string tagAt(const std::string& text, const std::string& name, size_t from, size_t& position)
{
  position = text.find("<" + name, from);
  if (position == std::string::npos)
    return std::string();
  const size_t end = text.find('>', position);
  return end == std::string::npos ? std::string() : text.substr(position, end - position + 1);
}

ScalarType vtiType(const std::string& value, const std::string& where)
{
  if (value == "UInt8")
    return ScalarType::UInt8;
  if (value == "Int16")
    return ScalarType::Int16;
  if (value == "UInt16")
    return ScalarType::UInt16;
  if (value == "Int32")
    return ScalarType::Int32;
  if (value == "Float32")
    return ScalarType::Float32;
  if (value == "Float64")
    return ScalarType::Float64;
  NV_THROW(where + "the array's type '" + clip(value) +
    "' cannot be streamed (UInt8, Int16, UInt16, Int32, Float32, Float64 can)");
}

/// The point array to train on: `wanted`, else the active scalars, else the first with one component.
std::string chooseArray(const std::string& text, size_t pointData, size_t pointDataEnd, const std::string& wanted,
  const std::string& activeScalars, const std::string& where)
{
  std::string first;
  for (size_t at = pointData;;)
  {
    size_t position = 0;
    const std::string tag = tagAt(text, "DataArray", at, position);
    if (tag.empty() || position > pointDataEnd)
      break;
    at = position + tag.size();
    const std::string name = attribute(tag, "Name");
    const std::string components = attribute(tag, "NumberOfComponents");
    if (!wanted.empty() ? name == wanted : (!activeScalars.empty() ? name == activeScalars : first.empty()))
    {
      if (!components.empty() && components != "1")
        NV_THROW(where + "the point array '" + clip(name) + "' has " + clip(components) +
          " components; one component per sample can be trained from the file");
      return tag;
    }
  }
  NV_THROW(where + (wanted.empty() ? std::string("no point array to train on")
                                   : "no point array named '" + clip(wanted) + "'"));
}

/// The byte count that precedes an appended block (header_type, byte order of the file).
uint64_t blockByteCount(const std::string& path, int64_t position, int headerBytes, bool bigEndian,
  const std::string& where)
{
  std::ifstream in(path, std::ios::binary);
  unsigned char bytes[8] = {};
  in.seekg(position);
  in.read(reinterpret_cast<char*>(bytes), headerBytes);
  if (in.gcount() != headerBytes)
    NV_THROW(where + "the file ends before the array's appended block (byte " + std::to_string(position) + ")");
  uint64_t count = 0;
  for (int k = 0; k < headerBytes; ++k)
    count |= static_cast<uint64_t>(bytes[bigEndian ? headerBytes - 1 - k : k]) << (8 * k);
  return count;
}
} // namespace

VolumeFileLayout readVtiLayout(const std::string& path, const std::string& arrayName)
{
  const std::string where = "'" + path + "': ";
  VolumeFileLayout layout;
  layout.headerPath = path;
  layout.dataPath = path;
  layout.format = "VTK XML image data";
  const std::string text = readHead(path, kMaxHeaderBytes, where);
  size_t position = 0;
  const std::string file = tagAt(text, "VTKFile", 0, position);
  if (file.empty() || attribute(file, "type") != "ImageData")
    NV_THROW(where + "not a VTK XML image data file");
  if (!attribute(file, "compressor").empty())
    NV_THROW(where + "the file is compressed (" + clip(attribute(file, "compressor")) +
      "): it cannot be read in pieces; save it without compression");
  layout.bigEndian = attribute(file, "byte_order") == "BigEndian";
  const int headerBytes = attribute(file, "header_type") == "UInt64" ? 8 : 4;
  const std::string image = tagAt(text, "ImageData", 0, position);
  const std::vector<double> extent = numbers(attribute(image, "WholeExtent"), ' ', where + "WholeExtent: ");
  if (extent.size() != 6)
    NV_THROW(where + "the image has no whole extent of 6 numbers");
  reals3(attribute(image, "Spacing").empty() ? "1 1 1" : attribute(image, "Spacing"), layout.spacing, ' ',
    where + "Spacing: ");
  reals3(attribute(image, "Origin").empty() ? "0 0 0" : attribute(image, "Origin"), layout.origin, ' ',
    where + "Origin: ");
  const std::string direction = attribute(image, "Direction");
  if (!direction.empty() &&
    numbers(direction, ' ', where + "Direction: ") != std::vector<double>{ 1, 0, 0, 0, 1, 0, 0, 0, 1 })
    NV_THROW(where + "the image is rotated (Direction " + clip(direction) + "); an axis-aligned image can be trained "
      "from on disk");
  for (double bound : extent)
    if (!(std::fabs(bound) < 1e15))
      NV_THROW(where + "the whole extent '" + clip(attribute(image, "WholeExtent")) + "' is not an image's");
  for (int axis = 0; axis < 3; ++axis)
  {
    layout.dims[axis] = static_cast<int64_t>(extent[2 * axis + 1] - extent[2 * axis]) + 1;
    layout.origin[axis] += extent[2 * axis] * layout.spacing[axis];
  }
  size_t secondPiece = 0;
  const size_t firstPiece = text.find("<Piece");
  if (firstPiece != std::string::npos && tagAt(text, "Piece", firstPiece + 1, secondPiece).size() > 0)
    NV_THROW(where + "the file holds several pieces; one piece can be trained from the file");
  size_t pointData = 0;
  const std::string pointTag = tagAt(text, "PointData", 0, pointData);
  const size_t pointDataEnd = text.find("</PointData>");
  if (pointTag.empty() || pointDataEnd == std::string::npos)
    NV_THROW(where + "the image has no point data");
  const std::string array =
    chooseArray(text, pointData, pointDataEnd, arrayName, attribute(pointTag, "Scalars"), where);
  layout.arrayName = attribute(array, "Name");
  layout.type = vtiType(attribute(array, "type"), where);
  if (attribute(array, "format") != "appended")
    NV_THROW(where + "the array '" + clip(layout.arrayName) + "' is stored inside the XML (" +
      clip(attribute(array, "format")) + "): save the file with appended raw data to train from it on disk");
  size_t appended = 0;
  const std::string appendedTag = tagAt(text, "AppendedData", 0, appended);
  if (appendedTag.empty() || attribute(appendedTag, "encoding") != "raw")
    NV_THROW(where + "the appended data is not raw (" + clip(attribute(appendedTag, "encoding")) +
      "): save the file with raw encoding to train from it on disk");
  const size_t marker = text.find('_', appended + appendedTag.size());
  if (marker == std::string::npos)
    NV_THROW(where + "the appended data has no start marker ('_') in the file's first bytes");
  const int64_t block = static_cast<int64_t>(marker + 1) + integer(attribute(array, "offset"), where + "offset: ");
  layout.dataOffset = block + headerBytes;
  const uint64_t count = blockByteCount(path, block, headerBytes, layout.bigEndian, where);
  int64_t samples = 1;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (layout.dims[axis] < 1 || samples > (int64_t(1) << 60) / layout.dims[axis])
      return layout; // finishLayout names the bad extent
    samples *= layout.dims[axis];
  }
  const int64_t expected = samples * static_cast<int64_t>(scalarSize(layout.type));
  if (count != static_cast<uint64_t>(expected))
    NV_THROW(where + "the array's block holds " + std::to_string(count) + " bytes but its extent needs " +
      std::to_string(expected));
  return layout;
}

} // namespace nv
