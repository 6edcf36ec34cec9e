// Out-of-core training's file layer (issue 22): the headers of .nhdr, .nrrd, .bov and .vti files give the samples'
// place, type, byte order, origin and spacing without reading them, and boxes read with pread equal the values
// written; every bad header or short file gives one clear nv::Error.
//   nvTestVolumeFile [case]
#include "Core/Error.h"
#include "OutOfCore/VolumeFileLayout.h"
#include "OutOfCore/VolumeFileReader.h"
#include "TempFolder.h"
#include "TestHarness.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace
{
using nv::ScalarType;

std::string tempDir()
{
  return nvtest::tempFolder();
}

std::string path(const std::string& name)
{
  return tempDir() + "/" + name;
}

void writeFile(const std::string& name, const std::string& bytes)
{
  std::ofstream out(path(name), std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// The test field: v(x, y, z) = x + 10 y + 100 z - 50 (negative values too).
double fieldValue(int64_t x, int64_t y, int64_t z)
{
  return static_cast<double>(x + 10 * y + 100 * z) - 50.0;
}

/// The field's samples as `type` in the given byte order.
std::string samples(const int64_t dims[3], ScalarType type, bool bigEndian)
{
  std::string bytes;
  const int size = static_cast<int>(nv::scalarSize(type));
  for (int64_t z = 0; z < dims[2]; ++z)
    for (int64_t y = 0; y < dims[1]; ++y)
      for (int64_t x = 0; x < dims[0]; ++x)
      {
        const double v = fieldValue(x, y, z) + (type == ScalarType::UInt8 || type == ScalarType::UInt16 ? 50.0 : 0.0);
        unsigned char b[8] = {};
        switch (type)
        {
          case ScalarType::UInt8: { const uint8_t s = static_cast<uint8_t>(v); std::memcpy(b, &s, 1); break; }
          case ScalarType::Int16: { const int16_t s = static_cast<int16_t>(v); std::memcpy(b, &s, 2); break; }
          case ScalarType::UInt16: { const uint16_t s = static_cast<uint16_t>(v); std::memcpy(b, &s, 2); break; }
          case ScalarType::Int32: { const int32_t s = static_cast<int32_t>(v); std::memcpy(b, &s, 4); break; }
          case ScalarType::Float32: { const float s = static_cast<float>(v) + 0.25f; std::memcpy(b, &s, 4); break; }
          case ScalarType::Float64: { const double s = v + 0.125; std::memcpy(b, &s, 8); break; }
          default: break;
        }
        if (bigEndian)
          for (int k = 0; k < size / 2; ++k)
            std::swap(b[k], b[size - 1 - k]);
        bytes.append(reinterpret_cast<char*>(b), size);
      }
  return bytes;
}

double expected(ScalarType type, int64_t x, int64_t y, int64_t z)
{
  const double v = fieldValue(x, y, z);
  if (type == ScalarType::UInt8 || type == ScalarType::UInt16)
    return v + 50.0;
  return v + (type == ScalarType::Float32 ? 0.25 : type == ScalarType::Float64 ? 0.125 : 0.0);
}

/// Reads the whole volume and a box inside it and compares both with the field; the number of wrong samples.
int wrongSamples(const nv::VolumeFileLayout& layout)
{
  nv::VolumeFileReader reader(layout);
  int wrong = 0;
  const int64_t* d = layout.dims;
  std::vector<double> all(static_cast<size_t>(layout.samples()));
  reader.readBox({ 0, 0, 0 }, { d[0], d[1], d[2] }, all.data());
  for (int64_t z = 0; z < d[2]; ++z)
    for (int64_t y = 0; y < d[1]; ++y)
      for (int64_t x = 0; x < d[0]; ++x)
        wrong += all[static_cast<size_t>((z * d[1] + y) * d[0] + x)] != expected(layout.type, x, y, z);
  std::vector<float> box(2 * 2 * 2);
  reader.readBox({ d[0] - 2, 1, d[2] - 2 }, { 2, 2, 2 }, box.data());
  for (int64_t z = 0; z < 2; ++z)
    for (int64_t y = 0; y < 2; ++y)
      for (int64_t x = 0; x < 2; ++x)
        wrong += box[static_cast<size_t>((z * 2 + y) * 2 + x)] !=
          static_cast<float>(expected(layout.type, d[0] - 2 + x, 1 + y, d[2] - 2 + z));
  return wrong;
}

std::string refusal(const std::string& name, const std::string& array = std::string())
{
  try
  {
    (void)nv::readVolumeFileLayout(path(name), array);
    return "";
  }
  catch (const nv::Error& e)
  {
    return e.what();
  }
}

bool contains(const std::string& text, const std::string& part)
{
  return text.find(part) != std::string::npos;
}

#define expectRefusal(...) expectRefusalAt(__LINE__, __VA_ARGS__)
void expectRefusalAt(int line, const std::string& name, const std::string& part, const std::string& array = "")
{
  const std::string message = refusal(name, array);
  if (!contains(message, part))
    nvtest::fail(__FILE__, line, name + ": '" + message + "' lacks '" + part + "'");
}

const int64_t kDims[3] = { 5, 4, 3 };

std::string nhdr(const std::string& type, const std::string& endian, const std::string& dataFile,
  const std::string& extra = std::string())
{
  return "NRRD0004\n# a comment\ntype: " + type + "\ndimension: 3\nsizes: 5 4 3\nencoding: raw\nendian: " + endian +
    "\nspacings: 0.5 0.25 2\nkey:=value\n" + extra + "data file: " + dataFile + "\n";
}
} // namespace

NV_TEST(nhdr_every_type_and_byte_order)
{
  const char* names[] = { "uchar", "short", "ushort", "int", "float", "double" };
  const ScalarType types[] = { ScalarType::UInt8, ScalarType::Int16, ScalarType::UInt16,
    ScalarType::Int32, ScalarType::Float32, ScalarType::Float64 };
  for (int k = 0; k < 6; ++k)
    for (int big = 0; big < 2; ++big)
    {
      const std::string data = "v" + std::to_string(k) + std::to_string(big) + ".raw";
      writeFile(data, samples(kDims, types[k], big != 0));
      writeFile("v.nhdr", nhdr(names[k], big ? "big" : "little", data));
      const nv::VolumeFileLayout layout = nv::readVolumeFileLayout(path("v.nhdr"));
      EXPECT_TRUE(layout.type == types[k] && layout.bigEndian == (big != 0) && layout.dataOffset == 0);
      EXPECT_TRUE(layout.dims[0] == 5 && layout.dims[1] == 4 && layout.dims[2] == 3);
      EXPECT_TRUE(layout.spacing[0] == 0.5 && layout.spacing[1] == 0.25 && layout.spacing[2] == 2.0);
      EXPECT_TRUE(layout.dataPath == path(data) && layout.arrayName == "v");
      EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
    }
}

NV_TEST(nhdr_byte_skip_and_space_directions)
{
  writeFile("skip.raw", std::string(7, 'x') + samples(kDims, ScalarType::Int16, true));
  writeFile("skip.nhdr", "NRRD0005\ntype: int16\ndimension: 3\nsizes: 5 4 3\nencoding: raw\nendian: big\n"
                         "space: left-posterior-superior\nspace directions: (0,0.5,0) (0.25,0,0) (0,0,2)\n"
                         "space origin: (1,-2,3.5)\nbyte skip: 7\ndata file: skip.raw\n");
  nv::VolumeFileLayout layout = nv::readVolumeFileLayout(path("skip.nhdr"));
  EXPECT_TRUE(layout.dataOffset == 7 && layout.spacing[0] == 0.5 && layout.spacing[1] == 0.25 && layout.origin[1] == -2.0 &&
    layout.origin[2] == 3.5);
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
  // "byte skip: -1": the samples are the file's last bytes.
  writeFile("end.raw", std::string(13, 'x') + samples(kDims, ScalarType::Int16, false));
  writeFile("end.nhdr", nhdr("short", "little", "end.raw", "byte skip: -1\n"));
  layout = nv::readVolumeFileLayout(path("end.nhdr"));
  EXPECT_TRUE(layout.dataOffset == 13);
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
}

NV_TEST(nrrd_attached_samples_follow_the_header)
{
  const std::string header = "NRRD0004\ntype: float\ndimension: 3\nsizes: 5 4 3\nencoding: raw\nendian: little\n\n";
  writeFile("attached.nrrd", header + samples(kDims, ScalarType::Float32, false));
  const nv::VolumeFileLayout layout = nv::readVolumeFileLayout(path("attached.nrrd"));
  EXPECT_TRUE(layout.dataPath == path("attached.nrrd") && layout.dataOffset == static_cast<int64_t>(header.size()));
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
}

NV_TEST(bov_nodal_and_zonal)
{
  writeFile("b.dat", std::string(16, '\0') + samples(kDims, ScalarType::Float64, true));
  writeFile("b.bov", "# a brick\nTIME: 0\nDATA_FILE: b.dat\nDATA_SIZE: 5 4 3\nDATA_FORMAT: DOUBLE\nVARIABLE: density\n"
                     "DATA_ENDIAN: BIG\nBRICK_ORIGIN: 1 2 3\nBRICK_SIZE: 4 6 4\nBYTE_OFFSET: 16\nDATA_COMPONENTS: 1\n");
  nv::VolumeFileLayout layout = nv::readVolumeFileLayout(path("b.bov"));
  EXPECT_TRUE(layout.arrayName == "density" && layout.dataOffset == 16 && layout.bigEndian);
  EXPECT_TRUE(layout.spacing[0] == 1.0 && layout.spacing[1] == 2.0 && layout.spacing[2] == 2.0 && layout.origin[0] == 1.0);
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
  writeFile("z.dat", samples(kDims, ScalarType::UInt8, false));
  writeFile("z.bov", "DATA_FILE: z.dat\nDATA_SIZE: 5 4 3\nDATA_FORMAT: BYTE\nCENTERING: zonal\nBRICK_SIZE: 5 8 6\n");
  layout = nv::readVolumeFileLayout(path("z.bov"));
  EXPECT_TRUE(layout.spacing[0] == 1.0 && layout.spacing[1] == 2.0 && layout.origin[0] == 0.5 && layout.origin[2] == 1.0);
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
}

namespace
{
/// A .vti with two appended raw point arrays ("other", then "f" of `type`), the second the active scalars.
std::string vti(const std::string& type, ScalarType stored, bool bigEndian, bool header64)
{
  const std::string other = samples(kDims, ScalarType::Int32, bigEndian);
  const std::string field = samples(kDims, stored, bigEndian);
  auto count = [&](const std::string& block) {
    std::string bytes;
    const int n = header64 ? 8 : 4;
    for (int k = 0; k < n; ++k)
      bytes += static_cast<char>((static_cast<uint64_t>(block.size()) >> (8 * (bigEndian ? n - 1 - k : k))) & 0xff);
    return bytes;
  };
  const std::string first = count(other) + other;
  return std::string("<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"") +
    (bigEndian ? "BigEndian" : "LittleEndian") + "\" header_type=\"" + (header64 ? "UInt64" : "UInt32") +
    "\">\n  <ImageData WholeExtent=\"2 6 0 3 1 3\" Origin=\"0 0 0\" Spacing=\"0.5 1 1\">\n"
    "  <Piece Extent=\"2 6 0 3 1 3\">\n    <PointData Scalars=\"f\">\n"
    "      <DataArray type=\"Int32\" Name=\"other\" format=\"appended\" offset=\"0\"/>\n"
    "      <DataArray type=\"" + type + "\" Name=\"f\" format=\"appended\" offset=\"" +
    std::to_string(first.size()) + "\"/>\n    </PointData>\n  </Piece>\n  </ImageData>\n"
    "  <AppendedData encoding=\"raw\">\n   _" + first + count(field) + field + "\n  </AppendedData>\n</VTKFile>\n";
}
} // namespace

NV_TEST(vti_appended_raw_arrays)
{
  writeFile("a.vti", vti("Float32", ScalarType::Float32, false, true));
  nv::VolumeFileLayout layout = nv::readVolumeFileLayout(path("a.vti"));
  EXPECT_TRUE(layout.arrayName == "f" && layout.type == ScalarType::Float32 && !layout.bigEndian);
  EXPECT_TRUE(layout.dims[0] == 5 && layout.dims[1] == 4 && layout.dims[2] == 3 && layout.origin[0] == 1.0 &&
    layout.origin[2] == 1.0 && layout.spacing[0] == 0.5);
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
  layout = nv::readVolumeFileLayout(path("a.vti"), "other");
  EXPECT_TRUE(layout.arrayName == "other" && layout.type == ScalarType::Int32);
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
  writeFile("b.vti", vti("UInt16", ScalarType::UInt16, true, false));
  layout = nv::readVolumeFileLayout(path("b.vti"));
  EXPECT_TRUE(layout.type == ScalarType::UInt16 && layout.bigEndian);
  EXPECT_NEAR_REL(wrongSamples(layout), 0.0, 0.0, 0.0);
}

NV_TEST(bad_headers_and_short_files_are_refused_clearly)
{
  const std::string data = samples(kDims, ScalarType::Int16, false);
  writeFile("short.raw", data.substr(0, data.size() - 1));
  writeFile("short.nhdr", nhdr("short", "little", "short.raw"));
  expectRefusal("short.nhdr", "promises 60 int16 samples (120 bytes from byte 0) but");
  expectRefusal("short.nhdr", "has 119 bytes: the file is truncated");
  writeFile("full.raw", data);
  writeFile("gz.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: 5 4 3\nencoding: gzip\ndata file: full.raw\n");
  expectRefusal("gz.nhdr", "encoded 'gzip'");
  writeFile("dim4.nhdr", "NRRD0004\ntype: short\ndimension: 4\nsizes: 2 5 4 3\ndata file: full.raw\n");
  expectRefusal("dim4.nhdr", "dimension 4");
  writeFile("long.nhdr", nhdr("long long", "little", "full.raw"));
  expectRefusal("long.nhdr", "'long long' cannot be streamed");
  writeFile("missing.nhdr", nhdr("short", "little", "nowhere.raw"));
  expectRefusal("missing.nhdr", "cannot open");
  writeFile("zero.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: 5 0 3\ndata file: full.raw\n");
  expectRefusal("zero.nhdr", "every size must be at least 1");
  writeFile("huge.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: 9223372036854775807 2 2\ndata file: full.raw\n");
  expectRefusal("huge.nhdr", "more samples than a file can hold");
  writeFile("spacing.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: 5 4 3\nspacings: 1 0 1\ndata file: full.raw\n");
  expectRefusal("spacing.nhdr", "must be positive");
  const char garbage[] = "\x7f\x01\x02 not a header at all";
  writeFile("garbage.nhdr", std::string(garbage, sizeof(garbage) - 1));
  expectRefusal("garbage.nhdr", "not a NRRD file");
  writeFile("nodata.bov", "DATA_SIZE: 5 4 3\nDATA_FORMAT: SHORT\n");
  expectRefusal("nodata.bov", "missing: DATA_FILE");
  writeFile("vec.bov", "DATA_FILE: full.raw\nDATA_SIZE: 5 4 3\nDATA_FORMAT: SHORT\nDATA_COMPONENTS: 3\n");
  expectRefusal("vec.bov", "one component per sample");
  std::string compressed = vti("Float32", ScalarType::Float32, false, true);
  compressed.replace(compressed.find("header_type"), 0, "compressor=\"vtkZLibDataCompressor\" ");
  writeFile("zlib.vti", compressed);
  expectRefusal("zlib.vti", "compressed (vtkZLibDataCompressor)");
  std::string base64 = vti("Float32", ScalarType::Float32, false, true);
  base64.replace(base64.find("encoding=\"raw\""), 14, "encoding=\"base64\"");
  writeFile("b64.vti", base64);
  expectRefusal("b64.vti", "not raw (base64)");
  std::string inlineArray = vti("Float32", ScalarType::Float32, false, true);
  inlineArray.replace(inlineArray.rfind("format=\"appended\""), 17, "format=\"ascii\"");
  writeFile("ascii.vti", inlineArray);
  expectRefusal("ascii.vti", "stored inside the XML (ascii)");
  std::string rotated = vti("Float32", ScalarType::Float32, false, true);
  rotated.replace(rotated.find("Spacing="), 0, "Direction=\"0 1 0 1 0 0 0 0 1\" ");
  writeFile("rotated.vti", rotated);
  expectRefusal("rotated.vti", "the image is rotated (Direction 0 1 0 1 0 0 0 0 1)");
  writeFile("named.vti", vti("Float32", ScalarType::Float32, false, true));
  expectRefusal("named.vti", "no point array named 'nothing'", "nothing");
  std::string cut = vti("Float32", ScalarType::Float32, false, true);
  writeFile("cut.vti", cut.substr(0, cut.size() - 40));
  expectRefusal("cut.vti", "the file is truncated");
  writeFile("x.mhd", "ObjectType = Image\n");
  expectRefusal("x.mhd", "'.mhd' file cannot be trained from on disk");
}

NV_TEST(a_file_that_shrinks_is_an_error_not_a_crash)
{
  writeFile("shrink.raw", samples(kDims, ScalarType::Int16, false));
  writeFile("shrink.nhdr", nhdr("short", "little", "shrink.raw"));
  const nv::VolumeFileLayout layout = nv::readVolumeFileLayout(path("shrink.nhdr"));
  nv::VolumeFileReader reader(layout);
  EXPECT_TRUE(truncate(path("shrink.raw").c_str(), 50) == 0);
  std::vector<float> box(5 * 4 * 3);
  std::string message;
  try
  {
    reader.readBox({ 0, 0, 0 }, { 5, 4, 3 }, box.data());
  }
  catch (const nv::Error& e)
  {
    message = e.what();
  }
  EXPECT_TRUE(contains(message, "the file ends there (it shrank)"));
}

namespace
{
/// One mutation of `text` (fixed stream `state`): a flipped byte, a digit run or a huge number spliced in, a cut, a
/// line repeated or dropped.
std::string mutate(const std::string& text, uint64_t& state)
{
  auto next = [&state]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<uint32_t>(state >> 33);
  };
  std::string out = text;
  const size_t at = out.empty() ? 0 : next() % out.size();
  static const char* splices[] = { "0", "-1", "99999999999999999999", "1e308", "nan", "inf", " ", "\n", ":", "\"",
    "4294967296", "18446744073709551615", "-9223372036854775808", "0.0", "\0" };
  switch (next() % 6)
  {
    case 0: out[at] = static_cast<char>(next() & 0xff); break;
    case 1: out.insert(at, splices[next() % (sizeof(splices) / sizeof(splices[0]))]); break;
    case 2: out.resize(at); break;
    case 3: { const size_t end = out.find('\n', at); out.insert(at, out.substr(at, end == std::string::npos ? 8 : end - at + 1)); break; }
    case 4: { const size_t end = out.find('\n', at); out.erase(at, end == std::string::npos ? std::string::npos : end - at + 1); break; }
    default: out.insert(at, std::to_string(next()) + std::to_string(next())); break;
  }
  return out;
}

/// Reads a header that may be anything: either an nv::Error, or a layout whose promised bytes lie in its data file
/// and whose samples can all be read. Returns false (and says why) when neither holds.
bool headerIsSafe(const std::string& name, std::string& why)
{
  nv::VolumeFileLayout layout;
  try
  {
    layout = nv::readVolumeFileLayout(path(name));
  }
  catch (const nv::Error&)
  {
    return true;
  }
  std::ifstream data(layout.dataPath, std::ios::binary | std::ios::ate);
  const int64_t size = data ? static_cast<int64_t>(data.tellg()) : -1;
  for (int a = 0; a < 3; ++a)
    if (layout.dims[a] < 1 || !(layout.spacing[a] > 0.0) || !std::isfinite(layout.spacing[a]) ||
      !std::isfinite(layout.origin[a]))
    {
      why = "accepted a layout with a bad size, spacing or origin";
      return false;
    }
  if (layout.dataOffset < 0 || size < layout.dataOffset + layout.bytes())
  {
    why = "accepted " + std::to_string(layout.bytes()) + " bytes from byte " + std::to_string(layout.dataOffset) +
      " of a " + std::to_string(size) + "-byte file";
    return false;
  }
  try
  {
    nv::VolumeFileReader reader(layout);
    std::vector<double> all(static_cast<size_t>(std::min<int64_t>(layout.samples(), 1 << 20)));
    if (layout.samples() <= (1 << 20))
      reader.readBox({ 0, 0, 0 }, { layout.dims[0], layout.dims[1], layout.dims[2] }, all.data());
    reader.readBox({ layout.dims[0] - 1, layout.dims[1] - 1, layout.dims[2] - 1 }, { 1, 1, 1 }, all.data());
  }
  catch (const nv::Error& e)
  {
    why = std::string("accepted, then failed to read: ") + e.what();
    return false;
  }
  return true;
}
} // namespace

NV_TEST(mutated_headers_are_refused_or_read_never_a_crash)
{
  // Thousands of damaged headers of every format (a deterministic mutation stream): each is refused with an
  // nv::Error or gives a layout that is all inside its data file and reads back (run under AddressSanitizer by
  // sanitize.Engine: no out-of-bounds read, no overflow).
  writeFile("m.raw", samples(kDims, ScalarType::Int16, false));
  writeFile("m.dat", samples(kDims, ScalarType::Float64, true));
  const std::string attached = "NRRD0004\ntype: float\ndimension: 3\nsizes: 5 4 3\nencoding: raw\nendian: little\n\n";
  const std::pair<std::string, std::string> headers[] = {
    { "m.nhdr", nhdr("short", "little", "m.raw", "space directions: (0.5,0,0) (0,0.25,0) (0,0,2)\nbyte skip: 0\n") },
    { "m.nrrd", attached + samples(kDims, ScalarType::Float32, false) },
    { "m.bov", "DATA_FILE: m.dat\nDATA_SIZE: 5 4 3\nDATA_FORMAT: DOUBLE\nVARIABLE: density\nDATA_ENDIAN: BIG\n"
               "BRICK_ORIGIN: 1 2 3\nBRICK_SIZE: 4 6 4\nBYTE_OFFSET: 0\nCENTERING: zonal\n" },
    { "m.vti", vti("Float32", ScalarType::Float32, false, true) },
  };
  int refused = 0, accepted = 0, unsafe = 0;
  for (const auto& header : headers)
  {
    uint64_t state = 20261127;
    for (int round = 0; round < 1500; ++round)
    {
      std::string text = header.second;
      for (int k = 0, n = 1 + round % 3; k < n; ++k)
        text = mutate(text, state);
      writeFile(header.first, text);
      std::string why;
      if (!headerIsSafe(header.first, why))
      {
        if (++unsafe <= 5)
          std::printf("  %s, round %d: %s\n", header.first.c_str(), round, why.c_str());
        continue;
      }
      try
      {
        (void)nv::readVolumeFileLayout(path(header.first));
        ++accepted;
      }
      catch (const nv::Error&)
      {
        ++refused;
      }
    }
  }
  std::printf("  %d mutated headers: %d refused, %d read, %d unsafe\n", refused + accepted + unsafe, refused,
    accepted, unsafe);
  EXPECT_TRUE(unsafe == 0 && refused > 1000 && accepted > 100);
}

int main(int argc, char** argv)
{
  return nvtest::runCasesInTempFolder(argc, argv);
}
