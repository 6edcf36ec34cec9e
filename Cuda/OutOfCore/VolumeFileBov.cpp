// NeuralVolume engine, out-of-core training: the header of a Brick of Values (.bov, VisIt's format): "KEY: value"
// lines naming one raw data file. Nodal centering (the default): BRICK_SIZE spans the first to the last sample;
// zonal: it spans the cells whose centres the samples are.
#include "Core/Error.h"
#include "VolumeFileLayout.h"
#include "VolumeFileText.h"

#include <algorithm>
#include <sstream>

namespace nv
{
namespace
{
using namespace volumefiletext;

ScalarType bovType(const std::string& value, const std::string& where)
{
  const std::string t = lower(trim(value));
  if (t == "byte" || t == "uint8")
    return ScalarType::UInt8;
  if (t == "short" || t == "int16")
    return ScalarType::Int16;
  if (t == "ushort" || t == "uint16")
    return ScalarType::UInt16;
  if (t == "int" || t == "int32")
    return ScalarType::Int32;
  if (t == "float")
    return ScalarType::Float32;
  if (t == "double")
    return ScalarType::Float64;
  NV_THROW(where + "DATA_FORMAT '" + clip(value) + "' cannot be streamed (BYTE, SHORT, INT, FLOAT, DOUBLE can)");
}

struct BovFields
{
  double brickOrigin[3] = { 0.0, 0.0, 0.0 };
  double brickSize[3] = { 0.0, 0.0, 0.0 };
  bool haveSize = false, zonal = false, sawFile = false, sawDims = false, sawFormat = false;
};

void bovField(VolumeFileLayout& layout, const std::string& key, const std::string& value, BovFields& fields,
  const std::string& where)
{
  if (key == "DATA_FILE")
  {
    layout.dataPath = besideHeader(layout.headerPath, trim(value));
    fields.sawFile = true;
  }
  else if (key == "DATA_SIZE")
  {
    integers3(value, layout.dims, where + "DATA_SIZE: ");
    fields.sawDims = true;
  }
  else if (key == "DATA_FORMAT")
  {
    layout.type = bovType(value, where);
    fields.sawFormat = true;
  }
  else if (key == "DATA_ENDIAN")
    layout.bigEndian = lower(trim(value)) == "big";
  else if (key == "BRICK_ORIGIN")
    reals3(value, fields.brickOrigin, ' ', where + "BRICK_ORIGIN: ");
  else if (key == "BRICK_SIZE")
  {
    reals3(value, fields.brickSize, ' ', where + "BRICK_SIZE: ");
    fields.haveSize = true;
  }
  else if (key == "CENTERING")
    fields.zonal = lower(trim(value)) == "zonal";
  else if (key == "BYTE_OFFSET")
    layout.dataOffset = integer(value, where + "BYTE_OFFSET: ");
  else if (key == "VARIABLE")
    layout.arrayName = trim(value);
  else if (key == "DATA_COMPONENTS" && integer(value, where + "DATA_COMPONENTS: ") != 1)
    NV_THROW(where + "DATA_COMPONENTS " + clip(value) + ": one component per sample can be trained from the file");
}
} // namespace

VolumeFileLayout readBovLayout(const std::string& path)
{
  const std::string where = "'" + path + "': ";
  VolumeFileLayout layout;
  layout.headerPath = path;
  layout.format = "BOV";
  std::istringstream in(readHead(path, kMaxHeaderBytes, where));
  std::string line;
  BovFields fields;
  while (std::getline(in, line))
  {
    const std::string content = trim(line.substr(0, line.find('#')));
    if (content.empty())
      continue;
    const size_t colon = content.find(':');
    if (colon == std::string::npos)
      NV_THROW(where + "cannot read the header line '" + clip(content) + "' (KEY: value expected)");
    bovField(layout, trim(content.substr(0, colon)), content.substr(colon + 1), fields, where);
  }
  if (!fields.sawFile || !fields.sawDims || !fields.sawFormat)
    NV_THROW(where + "a BOV header needs DATA_FILE, DATA_SIZE and DATA_FORMAT (missing: " +
      (!fields.sawFile ? "DATA_FILE" : !fields.sawDims ? "DATA_SIZE" : "DATA_FORMAT") + ")");
  for (int axis = 0; axis < 3; ++axis)
  {
    const int64_t n = layout.dims[axis];
    if (fields.haveSize && n >= 1)
    {
      // Nodal: n samples span the brick; zonal: n cells do, the samples at their centres.
      const int64_t steps = fields.zonal ? n : std::max<int64_t>(1, n - 1);
      layout.spacing[axis] = fields.brickSize[axis] / static_cast<double>(steps);
    }
    layout.origin[axis] = fields.brickOrigin[axis] + (fields.zonal ? 0.5 * layout.spacing[axis] : 0.0);
  }
  return layout;
}

} // namespace nv
