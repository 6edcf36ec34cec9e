// NeuralVolume engine, out-of-core training: the headers of raw volume files (VolumeFileLayout.h), each read without
// touching the samples and checked against the data file's size.
#include "VolumeFileLayout.h"

#include "Core/Error.h"
#include "VolumeFileText.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace nv
{

namespace
{
using namespace volumefiletext;

ScalarType nrrdType(const std::string& value, const std::string& where)
{
  const std::string t = lower(trim(value));
  if (t == "uchar" || t == "unsigned char" || t == "uint8" || t == "uint8_t")
    return ScalarType::UInt8;
  if (t == "short" || t == "short int" || t == "signed short" || t == "signed short int" || t == "int16" ||
    t == "int16_t")
    return ScalarType::Int16;
  if (t == "ushort" || t == "unsigned short" || t == "unsigned short int" || t == "uint16" || t == "uint16_t")
    return ScalarType::UInt16;
  if (t == "int" || t == "signed int" || t == "int32" || t == "int32_t")
    return ScalarType::Int32;
  if (t == "float")
    return ScalarType::Float32;
  if (t == "double")
    return ScalarType::Float64;
  NV_THROW(where + "the sample type '" + clip(value) +
    "' cannot be streamed (uint8, int16, uint16, int32, float, double can)");
}

/// The spacing of a NRRD "space directions" axis vector "(a,b,c)": its length.
double directionLength(const std::string& vector, const std::string& where)
{
  const std::string inner = trim(vector);
  if (inner.size() < 2 || inner.front() != '(' || inner.back() != ')')
    NV_THROW(where + "cannot read the space direction '" + clip(vector) + "'");
  double sum = 0.0;
  for (double c : numbers(inner.substr(1, inner.size() - 2), ',', where))
    sum += c * c;
  return std::sqrt(sum);
}

struct NrrdFields
{
  int64_t byteSkip = 0;
  bool sawType = false, sawSizes = false;
};

void nrrdField(VolumeFileLayout& layout, const std::string& key, const std::string& value, NrrdFields& fields,
  const std::string& where)
{
  if (key == "type")
  {
    layout.type = nrrdType(value, where);
    fields.sawType = true;
  }
  else if (key == "dimension" && trim(value) != "3")
    NV_THROW(where + "the header has dimension " + clip(value) + "; a volume has 3 (one component per sample)");
  else if (key == "sizes")
  {
    integers3(value, layout.dims, where + "sizes: ");
    fields.sawSizes = true;
  }
  else if (key == "encoding" && lower(trim(value)) != "raw")
    NV_THROW(where + "the samples are encoded '" + clip(value) +
      "', which cannot be read in pieces; save the volume with raw encoding");
  else if (key == "endian")
    layout.bigEndian = lower(trim(value)) == "big";
  else if (key == "spacings")
    reals3(value, layout.spacing, ' ', where + "spacings: ");
  else if (key == "space origin")
  {
    const std::string v = trim(value);
    if (v.size() < 2 || v.front() != '(' || v.back() != ')')
      NV_THROW(where + "cannot read the space origin '" + clip(value) + "'");
    reals3(v.substr(1, v.size() - 2), layout.origin, ',', where + "space origin: ");
  }
  else if (key == "space directions")
  {
    std::istringstream in(value);
    for (int axis = 0; axis < 3; ++axis)
    {
      std::string vector;
      if (!(in >> vector))
        NV_THROW(where + "the space directions give fewer than 3 axes");
      layout.spacing[axis] = directionLength(vector, where);
    }
  }
  else if (key == "byte skip")
    fields.byteSkip = integer(value, where + "byte skip: ");
  else if (key == "line skip" && integer(value, where + "line skip: ") != 0)
    NV_THROW(where + "'line skip' cannot be streamed; use 'byte skip'");
  else if (key == "data file" || key == "datafile")
  {
    const std::string v = trim(value);
    if (v.rfind("LIST", 0) == 0 || v.find('%') != std::string::npos || v.find(' ') != std::string::npos)
      NV_THROW(where + "a list or pattern of data files ('" + clip(v) + "') is not supported; one data file is");
    layout.dataPath = besideHeader(layout.headerPath, v);
  }
}

} // namespace

VolumeFileLayout readNrrdLayout(const std::string& path, bool detached)
{
  const std::string where = "'" + path + "': ";
  VolumeFileLayout layout;
  layout.headerPath = path;
  layout.format = detached ? "NRRD (detached header)" : "NRRD";
  const std::string text = readHead(path, kMaxHeaderBytes, where);
  if (text.compare(0, 4, "NRRD") != 0)
    NV_THROW(where + "not a NRRD file (it does not begin with 'NRRD')");
  NrrdFields fields;
  size_t lineStart = text.find('\n');
  bool ended = false;
  while (lineStart != std::string::npos)
  {
    const size_t lineEnd = text.find('\n', lineStart + 1);
    if (lineEnd == std::string::npos)
      break;
    std::string line = text.substr(lineStart + 1, lineEnd - lineStart - 1);
    lineStart = lineEnd;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    if (line.empty())
    {
      ended = true;
      break;
    }
    if (line[0] == '#' || line.find(":=") != std::string::npos)
      continue; // comments, key/value pairs
    const size_t colon = line.find(": ");
    if (colon == std::string::npos)
      NV_THROW(where + "cannot read the header line '" + clip(line) + "'");
    nrrdField(layout, lower(trim(line.substr(0, colon))), line.substr(colon + 2), fields, where);
  }
  if (!fields.sawType || !fields.sawSizes)
    NV_THROW(where + "the header gives no " + std::string(fields.sawType ? "sizes" : "type"));
  if (layout.dataPath.empty())
  {
    if (detached)
      NV_THROW(where + "the detached header names no data file ('data file:')");
    if (!ended)
      NV_THROW(where + "the header does not end (no blank line within its first " +
        std::to_string(kMaxHeaderBytes) + " bytes)");
    layout.dataPath = path; // the samples follow the header's blank line
    layout.dataOffset = static_cast<int64_t>(lineStart + 1);
  }
  if (fields.byteSkip < -1)
    NV_THROW(where + "byte skip " + std::to_string(fields.byteSkip) + " is not a byte count");
  if (fields.byteSkip == -1)
    finishLayout(layout, true); // "byte skip: -1": the samples are the data file's last bytes
  else
    layout.dataOffset += fields.byteSkip;
  return layout;
}

void finishLayout(VolumeFileLayout& layout, bool samplesEndTheFile)
{
  using namespace volumefiletext;
  const std::string where = "'" + layout.headerPath + "': ";
  int64_t samples = 1;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (layout.dims[axis] < 1)
      NV_THROW(where + "the header gives " + std::to_string(layout.dims[axis]) + " samples along axis " +
        std::to_string(axis) + "; every size must be at least 1");
    if (samples > std::numeric_limits<int64_t>::max() / 8 / layout.dims[axis])
      NV_THROW(where + "the header's sizes multiply to more samples than a file can hold");
    samples *= layout.dims[axis];
    if (!std::isfinite(layout.spacing[axis]) || layout.spacing[axis] <= 0.0)
      NV_THROW(where + "the spacing along axis " + std::to_string(axis) + " is " +
        std::to_string(layout.spacing[axis]) + "; it must be positive and finite");
    if (!std::isfinite(layout.origin[axis]))
      NV_THROW(where + "the origin is not finite");
  }
  const int64_t size = fileSize(layout.dataPath, where);
  if (samplesEndTheFile)
    layout.dataOffset = std::max<int64_t>(0, size - layout.bytes());
  if (layout.dataOffset < 0)
    NV_THROW(where + "the samples would start before the data file's first byte");
  if (size - layout.dataOffset < layout.bytes())
  {
    std::ostringstream message;
    message << where << "the header promises " << layout.samples() << " " << scalarTypeName(layout.type)
            << " samples (" << layout.bytes() << " bytes from byte " << layout.dataOffset << ") but '"
            << layout.dataPath << "' has " << size << " bytes: the file is truncated or the header is wrong";
    NV_THROW(message.str());
  }
  if (layout.arrayName.empty())
    layout.arrayName = fileStem(layout.headerPath);
}

VolumeFileLayout readVolumeFileLayout(const std::string& path, const std::string& arrayName)
{
  using namespace volumefiletext;
  const std::string extension = lower(fileExtension(path));
  VolumeFileLayout layout;
  if (extension == ".nhdr")
    layout = readNrrdLayout(path, true);
  else if (extension == ".nrrd")
    layout = readNrrdLayout(path, false);
  else if (extension == ".bov")
    layout = readBovLayout(path);
  else if (extension == ".vti")
    layout = readVtiLayout(path, arrayName);
  else
    NV_THROW("'" + path + "': a '" + extension + "' file cannot be trained from on disk (.nhdr, .nrrd, .bov and "
      ".vti can)");
  finishLayout(layout, false);
  return layout;
}

} // namespace nv
