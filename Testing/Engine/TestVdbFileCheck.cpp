// nv::VdbFileCheck: valid OpenVDB layouts are accepted with their grids' byte ranges; truncated, empty and bit-flipped
// files throw nv::Error with a clear message, never crash. With --data DIR, the real smoke.vdb too (else skipped).
//   nvTestVdbFileCheck [case] [--data DIR]
#include "Core/Error.h"
#include "Core/VdbFileCheck.h"
#include "SyntheticVdb.h"
#include "TestHarness.h"

#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace
{
std::string& dataDir()
{
  static std::string dir;
  return dir;
}

using Bytes = std::vector<uint8_t>;

/// The check's message, or "" when it accepted the bytes; anything but nv::Error fails the test.
std::string refusal(const Bytes& b, size_t n)
{
  try
  {
    (void)nv::VdbFileCheck::checkBytes(b.data(), n);
    return "";
  }
  catch (const nv::Error& e)
  {
    return e.what();
  }
}

bool contains(const std::string& s, const std::string& part)
{
  return s.find(part) != std::string::npos;
}

nvtest::SyntheticVdb threeGrids()
{
  nvtest::SyntheticVdb v;
  v.grids.resize(3);
  v.grids[1].name = "temperature";
  v.grids[1].halfFloat = true;
  v.grids[1].blockBytes = 300;
  v.grids[2].name = "density_copy";
  v.grids[2].instanceParent = "density";
  return v;
}

void expectSummary(nvtest::SyntheticVdb v)
{
  const Bytes b = v.build();
  const nv::VdbFileSummary s = nv::VdbFileCheck::checkBytes(b.data(), b.size());
  EXPECT_TRUE(s.formatVersion == v.version);
  EXPECT_TRUE(s.fileSize == b.size());
  EXPECT_TRUE(s.hasGridOffsets == v.hasGridOffsets);
  EXPECT_TRUE(s.metadataCount == 1);
  EXPECT_TRUE(s.gridCount == int32_t(v.grids.size()));
  EXPECT_TRUE(s.grids.size() == (v.hasGridOffsets ? v.grids.size() : 1));
  for (size_t i = 0; i < s.grids.size(); ++i)
  {
    const nv::VdbFileSummary::Grid& g = s.grids[i];
    const nvtest::SyntheticVdb::Grid& w = v.grids[i];
    EXPECT_TRUE(g.name == w.name && g.type == w.type && g.halfFloat == w.halfFloat);
    EXPECT_TRUE(g.instanceParent == (v.version >= 216 ? w.instanceParent : ""));
    EXPECT_TRUE(g.descriptorPos == w.descriptorPos);
    EXPECT_TRUE(g.gridPos == (v.hasGridOffsets ? w.gridPos : s.grids[0].gridPos));
    EXPECT_TRUE(g.blockPos == w.blockPos && g.endPos == w.endPos);
    EXPECT_TRUE(g.metadataCount == 5);
    EXPECT_TRUE(g.compression == (v.version >= 222 ? 2u : 0u));
    EXPECT_TRUE(g.transformType == (v.version >= 219 ? "UniformScaleTranslateMap" : ""));
  }
  if (v.hasGridOffsets && !s.grids.empty())
    EXPECT_TRUE(s.grids.back().endPos == b.size());
}
} // namespace

NV_TEST(valid_layouts)
{
  expectSummary(nvtest::SyntheticVdb());
  expectSummary(threeGrids());
  for (uint32_t version : { 213u, 216u, 218u, 219u, 220u, 221u, 222u, 223u })
  {
    nvtest::SyntheticVdb v = threeGrids();
    v.version = version;
    if (version < 216)
      v.grids.pop_back(); // no instances before 216
    expectSummary(v);
  }
  nvtest::SyntheticVdb streamed = threeGrids();
  streamed.hasGridOffsets = false;
  expectSummary(streamed);
  nvtest::SyntheticVdb none;
  none.grids.clear();
  expectSummary(none);
}

NV_TEST(long_names_are_clipped)
{
  nvtest::SyntheticVdb v;
  v.grids[0].name = std::string(100000, 'x') + "\x01\xff";
  const Bytes b = v.build();
  const nv::VdbFileSummary s = nv::VdbFileCheck::checkBytes(b.data(), b.size());
  EXPECT_TRUE(s.grids.size() == 1 && s.grids[0].name == std::string(nv::VdbFileCheck::kKeptChars, 'x') + "...");
  // A truncated copy names the grid clipped: the message stays short.
  const std::string m = refusal(b, b.size() - 1);
  EXPECT_TRUE(contains(m, "truncated") && m.size() < 1000);
}

NV_TEST(every_truncation_is_refused)
{
  const Bytes b = threeGrids().build();
  EXPECT_TRUE(contains(refusal(b, 0), "the file is empty (0 bytes)"));
  EXPECT_TRUE(contains(refusal(b, 5), "only 5 bytes"));
  int checked = 0;
  for (size_t n = 1; n < b.size(); ++n)
  {
    const std::string m = refusal(b, n);
    if (m.empty() || !contains(m, "truncated") || m.size() > 1000)
      nvtest::fail(__FILE__, __LINE__, "cut at " + std::to_string(n) + ": '" + m + "'");
    ++checked;
  }
  EXPECT_TRUE(checked == int(b.size()) - 1);
  // A cut inside the first grid's data names it and the byte it claims.
  nvtest::SyntheticVdb v = threeGrids();
  v.build();
  const size_t cut = size_t(v.grids[0].blockPos + 3);
  const std::string m = refusal(b, cut);
  EXPECT_TRUE(contains(m, "the file ends at byte " + std::to_string(cut) + " but its grid 'density' claims bytes up to " +
    std::to_string(v.grids[0].endPos) + ": the file is truncated"));
}

NV_TEST(bit_flips_in_the_headers_are_refused)
{
  nvtest::SyntheticVdb v = threeGrids();
  const Bytes b = v.build();
  // Bits whose flip the check always sees: the magic, the version (224: every flip leaves 213-224), the offsets
  // flag, the high bytes of the string lengths and counts (far past a file of a few hundred bytes), and every grid
  // position (the grid starts where its descriptor ends).
  std::vector<std::pair<size_t, size_t>> always = { { 0, 8 }, { 8, 12 }, { 20, 21 } };
  always.push_back({ 57 + 2, 57 + 4 }); // the file's metadata count: bytes 57-60
  always.push_back({ 61 + 2, 61 + 4 }); // the length of its first entry's name
  for (const auto& g : v.grids)
  {
    always.push_back({ g.descriptorPos + 2, g.descriptorPos + 4 }); // the name's length
    always.push_back({ g.gridPos - 24, g.gridPos - 16 });           // the grid position
  }
  for (const auto& range : always)
    for (size_t at = range.first; at < range.second; ++at)
      for (int bit = 0; bit < 8; ++bit)
      {
        Bytes f = b;
        f[at] ^= uint8_t(1u << bit);
        if (refusal(f, f.size()).empty())
          nvtest::fail(__FILE__, __LINE__, "flip of bit " + std::to_string(bit) + " of byte " + std::to_string(at) +
            " accepted");
      }
  // Every other bit of the file: refused with nv::Error or accepted, never a crash or another exception.
  int refused = 0;
  for (size_t at = 0; at < b.size(); ++at)
    for (int bit = 0; bit < 8; ++bit)
    {
      Bytes f = b;
      f[at] ^= uint8_t(1u << bit);
      refused += refusal(f, f.size()).empty() ? 0 : 1;
    }
  std::printf("  %d of %zu single-bit flips refused\n", refused, b.size() * 8);
  EXPECT_TRUE(refused > int(b.size())); // most header bits matter; the filler's do not
}

NV_TEST(random_bit_flips)
{
  const Bytes b = threeGrids().build();
  for (unsigned seed = 1; seed <= 200; ++seed)
  {
    std::mt19937 rng(seed);
    Bytes f = b;
    const int flips = 1 + int(rng() % 8);
    for (int i = 0; i < flips; ++i)
      f[rng() % f.size()] ^= uint8_t(1u << (rng() % 8));
    (void)refusal(f, f.size()); // only nv::Error may leave the check
    (void)refusal(f, rng() % f.size());
  }
}

NV_TEST(files)
{
  EXPECT_THROW_MSG(nv::VdbFileCheck::checkFile("/nonexistent/none.vdb"), "cannot open the file");
  EXPECT_THROW_MSG(nv::VdbFileCheck::checkFile("/tmp"), "not a regular file");
  const std::string path = "nvTestVdbFileCheck_tmp.vdb";
  const Bytes b = threeGrids().build();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size() - 10));
  }
  EXPECT_THROW_MSG(nv::VdbFileCheck::checkFile(path), "claims bytes up to");
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
  }
  EXPECT_TRUE(nv::VdbFileCheck::checkFile(path).grids.size() == 3);
  std::remove(path.c_str());
}

NV_TEST(smoke_vdb)
{
  const std::string path = dataDir() + "/openvdb_smoke1/smoke.vdb";
  std::ifstream in(path, std::ios::binary);
  if (dataDir().empty() || !in)
  {
    std::printf("  SKIP: %s not found (--data DIR)\n", path.c_str());
    return;
  }
  const Bytes b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const nv::VdbFileSummary s = nv::VdbFileCheck::checkFile(path);
  EXPECT_TRUE(s.formatVersion == 222 && s.hasGridOffsets && s.metadataCount == 1 && s.grids.size() == 1);
  if (s.grids.size() == 1)
  {
    const nv::VdbFileSummary::Grid& g = s.grids[0];
    EXPECT_TRUE(g.name == "density" && g.type == "Tree_float_5_4_3" && g.halfFloat);
    EXPECT_TRUE(g.gridPos == 184 && g.blockPos == 210560 && g.endPos == b.size() && g.metadataCount == 12);
    EXPECT_TRUE(g.transformType == "UniformScaleTranslateMap");
  }
  for (double fraction : { 0.25, 0.5, 0.75 })
  {
    const size_t n = size_t(double(b.size()) * fraction);
    const std::string m = refusal(b, n);
    EXPECT_TRUE(contains(m, "the file ends at byte " + std::to_string(n) + " but its grid 'density' claims bytes up "
      "to " + std::to_string(b.size()) + ": the file is truncated"));
  }
}

int main(int argc, char** argv)
{
  std::vector<char*> rest = { argv[0] };
  for (int i = 1; i < argc; ++i)
  {
    if (std::string(argv[i]) == "--data" && i + 1 < argc)
      dataDir() = argv[++i];
    else
      rest.push_back(argv[i]);
  }
  return nvtest::runCases(int(rest.size()), rest.data());
}
