// Model serialization: bit-exact round trip and clear errors for bad input, including crafted files that pass their
// checksum (each refused before the reader allocates more than kCraftedAllocationCap bytes at once).
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/Macrocells.h"
#include "Core/Serialization.h"
#include "CraftedModelFiles.h"
#include "TestHarness.h"

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <random>

using namespace nv;

namespace
{
Model sample(Precision p)
{
  ModelConfig c;
  c.encoding.levels = 5;
  c.encoding.featuresPerLevel = 8;
  c.encoding.log2TableSize = 11;
  c.encoding.finestResolution = 100;
  c.network.width = 32;
  c.network.hiddenLayers = 3;
  Model m(c);
  m.initialize(42);
  std::mt19937 rng(1);
  std::normal_distribution<float> g(0.f, 1.f);
  for (float& v : m.params())
    v = g(rng);
  m.source.dims[0] = 64;
  m.source.dims[1] = 32;
  m.source.dims[2] = 7;
  m.source.origin[1] = -2.5;
  m.source.spacing[2] = 0.125;
  m.source.bounds[5] = 0.75;
  m.source.valueMin = -17.25;
  m.source.valueMax = 1e6;
  m.source.arrayName = "density";
  m.source.association = 1;
  m.source.rawBytes = 64 * 32 * 7 * 2;
  m.stats.steps = 1234;
  m.stats.seconds = 5.5;
  m.stats.psnr = 41.25;
  m.stats.maxError = 0.01;
  m.stats.invalidSamples = 3;
  m.stats.device = "CPU";
  m.quantize(p);
  return m;
}
} // namespace

NV_TEST(round_trip_is_bit_exact)
{
  for (Precision p : { Precision::Float32, Precision::Float16 })
  {
    const Model a = sample(p);
    const auto bytes = serialize(a);
    const Model b = deserialize(bytes);
    EXPECT_TRUE(std::memcmp(a.params().data(), b.params().data(), a.params().size() * 4) == 0);
    EXPECT_TRUE(serialize(b) == bytes);
    EXPECT_TRUE(b.source.arrayName == "density" && b.source.dims[2] == 7 && b.source.origin[1] == -2.5);
    EXPECT_TRUE(b.source.valueMax == 1e6 && b.stats.steps == 1234 && b.stats.device == "CPU");
    EXPECT_TRUE(b.config().network.hiddenLayers == 3 && b.config().encoding.featuresPerLevel == 8);
    EXPECT_TRUE(b.storagePrecision() == p);
    const int64_t expected = int64_t(a.paramCount()) * (p == Precision::Float16 ? 2 : 4);
    EXPECT_TRUE(a.parameterBytes() == expected);
    EXPECT_TRUE(int64_t(bytes.size()) > expected && int64_t(bytes.size()) < expected + 1024);
  }
}

NV_TEST(domain_mask_round_trip_and_versions)
{
  // Without a domain mask a model is written as version 1, byte for byte as before version 2 existed; with one as
  // version 2, its bits restored exactly. Both versions are read. Broken run lengths give clear errors.
  Model a = sample(Precision::Float16);
  const auto v1 = serialize(a);
  uint32_t version = 0;
  std::memcpy(&version, v1.data() + 8, 4);
  EXPECT_TRUE(version == 1);
  const int64_t samples = a.source.dims[0] * a.source.dims[1] * a.source.dims[2];
  a.source.domain.assign(size_t((samples + 31) / 32), 0u);
  std::mt19937 rng(3);
  for (int64_t i = 0; i < samples; ++i)
    if ((i / 37) % 3 != 0 || rng() % 11 == 0) // runs of many lengths
      a.source.domain[size_t(i >> 5)] |= 1u << (i & 31);
  const auto v2 = serialize(a);
  std::memcpy(&version, v2.data() + 8, 4);
  EXPECT_TRUE(version == 2);
  const Model b = deserialize(v2);
  EXPECT_TRUE(b.source.domain == a.source.domain);
  EXPECT_TRUE(serialize(b) == v2);
  EXPECT_TRUE(deserialize(v1).source.domain.empty());
  const float in[3] = { 0.0f, 0.0f, 0.0f }; // sample 0: (0 / 37) % 3 == 0 -> outside unless the random bit set it
  EXPECT_TRUE(inDomain(b.source, in) == (((a.source.domain[0] & 1u) != 0u)));
  // A run that overshoots the samples, with the checksum recomputed so that the structure check is what fails.
  auto bad = v2;
  uint64_t count = 0;
  const size_t countAt = v1.size() - 4; // the run count follows the parameters, where v1's checksum was
  std::memcpy(&count, bad.data() + countAt, 8);
  EXPECT_TRUE(count >= 2 && countAt + 8 + 4 * count + 4 == bad.size());
  uint32_t first = 0;
  std::memcpy(&first, bad.data() + countAt + 8, 4);
  first += uint32_t(samples);
  std::memcpy(bad.data() + countAt + 8, &first, 4);
  const uint32_t crc = crc32(bad.data(), bad.size() - 4);
  std::memcpy(bad.data() + bad.size() - 4, &crc, 4);
  EXPECT_THROW_MSG(deserialize(bad), "runs of the domain mask exceed");
}

NV_TEST(occupancy_mask_round_trip_is_version_3)
{
  // A sparse source's occupancy (one bit per macrocell) and background: version 3, restored exactly, with or without
  // a domain mask; v1 and v2 models keep their versions; a broken run or a NaN background is a clear error.
  Model a = sample(Precision::Float16);
  const int64_t words = occupancyWords(a.source.dims);
  const MacrocellLayout cells = macrocellLayout(a.source.dims);
  const int64_t count = int64_t(cells.dims[0]) * cells.dims[1] * cells.dims[2];
  a.source.occupancy.assign(size_t(words), 0u);
  for (int64_t c = 0; c < count; ++c)
    if (c % 5 == 1 || c % 7 == 0)
      a.source.occupancy[size_t(c >> 5)] |= 1u << (c & 31);
  a.source.background = -0.25;
  const auto v3 = serialize(a);
  uint32_t version = 0;
  std::memcpy(&version, v3.data() + 8, 4);
  EXPECT_TRUE(version == 3);
  const Model b = deserialize(v3);
  EXPECT_TRUE(b.source.occupancy == a.source.occupancy && b.source.background == -0.25 && b.source.domain.empty());
  EXPECT_TRUE(serialize(b) == v3);
  // With a domain mask as well.
  const int64_t samples = a.source.dims[0] * a.source.dims[1] * a.source.dims[2];
  a.source.domain.assign(size_t((samples + 31) / 32), 0xFFFF00FFu);
  const Model c = deserialize(serialize(a));
  EXPECT_TRUE(c.source.occupancy == a.source.occupancy && c.source.domain.size() == a.source.domain.size());
  // A NaN background, with the checksum fixed so that the check, not the checksum, refuses it.
  auto bad = v3;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(bad.data() + bad.size() - 12, &nan, 8);
  const uint32_t crc = crc32(bad.data(), bad.size() - 4);
  std::memcpy(bad.data() + bad.size() - 4, &crc, 4);
  EXPECT_THROW_MSG(deserialize(bad), "background that is not finite");
}

NV_TEST(file_round_trip)
{
  const Model a = sample(Precision::Float16);
  const std::string path = "nv_test_model.nvnet";
  saveModel(a, path);
  const Model b = loadModel(path);
  EXPECT_TRUE(a.params() == b.params());
  std::remove(path.c_str());
  EXPECT_THROW_MSG(loadModel("/nonexistent/dir/x.nvnet"), "cannot open");
}

NV_TEST(corrupt_inputs_give_clear_errors)
{
  const auto bytes = serialize(sample(Precision::Float16));
  // Truncated at many lengths.
  for (size_t len : { size_t(0), size_t(5), size_t(12), size_t(40), bytes.size() / 2, bytes.size() - 1 })
  {
    bool thrown = false;
    try
    {
      deserialize(bytes.data(), len);
    }
    catch (const Error& e)
    {
      const std::string w = e.what();
      thrown = w.find("truncated") != std::string::npos || w.find("not a NeuralVolume model") != std::string::npos;
    }
    EXPECT_TRUE(thrown);
  }
  // One flipped bit anywhere after the magic is caught by the checksum or field checks.
  for (size_t pos : { size_t(20), size_t(100), bytes.size() / 2, bytes.size() - 2 })
  {
    auto bad = bytes;
    bad[pos] ^= 0x10;
    EXPECT_THROW_MSG(deserialize(bad), "corrupt");
  }
  auto magic = bytes;
  magic[0] = 'X';
  EXPECT_THROW_MSG(deserialize(magic), "not a NeuralVolume model");
  auto version = bytes;
  version[8] = 99;
  EXPECT_THROW_MSG(deserialize(version), "unsupported NeuralVolume model version 99");
}

NV_TEST(half_conversion)
{
  EXPECT_TRUE(floatToHalf(1.0f) == 0x3C00 && floatToHalf(-2.0f) == 0xC000 && floatToHalf(0.0f) == 0);
  EXPECT_TRUE(floatToHalf(65504.0f) == 0x7BFF && floatToHalf(1e6f) == 0x7C00);
  EXPECT_TRUE(halfToFloat(0x0001) == std::ldexp(1.0f, -24)); // smallest subnormal
  EXPECT_TRUE(floatToHalf(1.0f + std::ldexp(1.0f, -11)) == 0x3C00); // tie rounds to even
  EXPECT_TRUE(floatToHalf(1.0f + 3 * std::ldexp(1.0f, -11)) == 0x3C02);
  for (uint32_t h = 0; h < 0x7C00; ++h) // every finite positive half survives the round trip
    if (floatToHalf(halfToFloat(uint16_t(h))) != h)
    {
      nvtest::fail(__FILE__, __LINE__, "half round trip " + std::to_string(h));
      break;
    }
}

// ---- Crafted files: every field of a model that passes its checksum is checked against the bytes present and the
// bounds of Model.h before anything large is allocated.

NV_TEST(crafted_offsets_match_the_writer)
{
  // The test's offsets are those of the format (else every crafted case below would patch the wrong field).
  const Model m = craftedModel(Precision::Float16);
  const auto b = serialize(m);
  EXPECT_TRUE(peek<uint32_t>(b, kAtVersion) == 1 && peek<int32_t>(b, kAtLevels) == 4);
  EXPECT_TRUE(peek<int32_t>(b, kAtFeatures) == 2 && peek<int32_t>(b, kAtLog2Table) == 10);
  EXPECT_TRUE(peek<int32_t>(b, kAtFinest) == 64 && peek<double>(b, kAtPerLevelScale) == 0.0);
  EXPECT_TRUE(peek<int64_t>(b, kAtDims) == 64 && peek<int64_t>(b, kAtDims + 16) == 7);
  EXPECT_TRUE(peek<double>(b, kAtSpacing) == 0.5 && peek<double>(b, kAtBounds + 8) == 31.5);
  EXPECT_TRUE(peek<double>(b, kAtValueMin) == 0.0 && peek<int32_t>(b, kAtAssociation) == 0);
  EXPECT_TRUE(peek<uint32_t>(b, kAtNameLength) == 3);
  EXPECT_TRUE(peek<uint64_t>(b, parameterCountAt(b)) == m.paramCount());
  EXPECT_TRUE(m.paramCount() == 8592 && b.size() > 17000 && b.size() < 18000); // "a 17 KB array"
}

NV_TEST(crafted_source_grids_are_refused_before_allocating)
{
  const auto good = serialize(craftedModel(Precision::Float16));
  struct Dims
  {
    int64_t d[3];
    const char* message;
    const char* what;
  };
  const Dims cases[] = {
    { { (int64_t(1) << 62) + 1, 4, 16 }, "source dimension 0 is 4611686018427387905", "dims (2^62+1, 4, 16)" },
    { { 4096, 4096, 4096 }, "at most 17179869184 (2^34) samples", "dims 4096^3" },
    { { 0, 4, 4 }, "source dimension 0 is 0", "zero dims" },
    { { 4, -3, 4 }, "source dimension 1 is -3", "negative dims" },
    { { 4, 4, (int64_t(1) << 20) + 1 }, "source dimension 2 is 1048577", "an axis above 2^20" },
    { { int64_t(1) << 20, int64_t(1) << 20, 1 << 20 }, "(2^34) samples", "2^60 samples, no wrap" },
    { { -(int64_t(1) << 62), -(int64_t(1) << 62), 1 }, "source dimension 0 is", "a product that wraps to 0" },
  };
  for (const Dims& c : cases)
  {
    auto bad = good;
    for (int a = 0; a < 3; ++a)
      patch<int64_t>(bad, kAtDims + 8 * a, c.d[a]);
    fixChecksum(bad);
    expectRefused(bad, c.message, c.what);
  }
  // At the bounds: 2^20 x 2^14 samples (2^34) and 2048^3 are a model's to state (no mask: nothing allocated for
  // them), and inspectModel() reports the bytes deserialize() will allocate: the parameters only.
  for (const Dims& c : { Dims{ { int64_t(1) << 20, int64_t(1) << 14, 1 }, "", "" }, Dims{ { 2048, 2048, 2048 }, "", "" } })
  {
    auto ok = good;
    for (int a = 0; a < 3; ++a)
      patch<int64_t>(ok, kAtDims + 8 * a, c.d[a]);
    fixChecksum(ok);
    const ModelFileInfo info = inspectModel(ok.data(), ok.size());
    EXPECT_TRUE(info.hostBytes == 8592u * 4 && info.parameterCount == 8592u && !info.hasDomain);
    const Model m = deserialize(ok);
    EXPECT_TRUE(m.source.dims[0] == c.d[0] && m.source.dims[2] == c.d[2] && m.params().size() == 8592u);
  }
}

NV_TEST(crafted_geometry_and_ranges_are_refused)
{
  const auto good = serialize(craftedModel(Precision::Float16));
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  struct Field
  {
    size_t at;
    double value;
    const char* message;
  };
  const Field cases[] = {
    { kAtOrigin, nan, "source origin 0 is not finite" },
    { kAtOrigin + 16, -inf, "source origin 2 is not finite" },
    { kAtSpacing + 8, -0.5, "source spacing 1 is -0.500000; it must be positive" },
    { kAtSpacing, 0.0, "source spacing 0 is 0.000000" },
    { kAtSpacing + 16, nan, "source spacing 2 is nan" },
    { kAtBounds + 8, inf, "source bounds 0.000000 .. inf on axis 0" },
    { kAtBounds + 16, 100.0, "on axis 1: they must be finite with min <= max" }, // ymin 100 > ymax 15.5
    { kAtValueMin, nan, "source value range nan" },
    { kAtValueMin, 2.0, "source value range 2.000000 .. 1.000000" },
  };
  for (const Field& c : cases)
  {
    auto bad = good;
    patch<double>(bad, c.at, c.value);
    fixChecksum(bad);
    expectRefused(bad, c.message, c.message);
  }
  auto association = good;
  patch<int32_t>(association, kAtAssociation, 7);
  fixChecksum(association);
  expectRefused(association, "source association 7", "association");
  // The writer refuses the same: every model it writes reads back.
  Model m = craftedModel(Precision::Float16);
  m.source.origin[1] = nan;
  EXPECT_THROW_MSG(serialize(m), "source origin 1 is not finite");
  m = craftedModel(Precision::Float16);
  m.source.spacing[2] = -1.0;
  EXPECT_THROW_MSG(serialize(m), "source spacing 2 is -1.000000");
}

NV_TEST(crafted_tables_and_counts_are_refused_before_allocating)
{
  const auto good = serialize(craftedModel(Precision::Float16));
  // A 17 KB model declaring a 2^24 table over 16 levels of 4 features (about 2^30 parameters, 4.3 GB as fp32):
  // refused by comparing counts before the parameters are allocated, whether or not the stored count agrees.
  auto huge = good;
  patch<int32_t>(huge, kAtLevels, 16);
  patch<int32_t>(huge, kAtFeatures, 4);
  patch<int32_t>(huge, kAtLog2Table, 24);
  patch<int32_t>(huge, kAtFinest, 4096);
  fixChecksum(huge);
  ModelConfig big;
  big.encoding.log2TableSize = 24;
  big.network.width = 16;
  big.network.hiddenLayers = 2;
  const uint64_t needed = uint64_t(Model(ModelConfig{ big.encoding, { 16, 1 } }).encodingParamCount()) + 64 * 16 + 16 * 16 + 16;
  EXPECT_TRUE(needed > (uint64_t(1) << 29));
  expectRefused(huge, "8592 parameters stored, the configuration needs " + std::to_string(needed), "a huge table");
  patch<uint64_t>(huge, parameterCountAt(huge), needed);
  fixChecksum(huge);
  expectRefused(huge, "bytes end inside 'parameters'", "a huge table with its count");
  // The largest table a configuration allows (2^31 parameters) is refused by the layout, never allocated.
  auto largest = good;
  patch<int32_t>(largest, kAtLevels, 32);
  patch<int32_t>(largest, kAtFeatures, 8);
  patch<int32_t>(largest, kAtLog2Table, 26);
  patch<int32_t>(largest, kAtFinest, 1 << 20);
  fixChecksum(largest);
  expectRefused(largest, "hash table too large", "32 levels x 8 features x 2^26");
  // 32 levels at a per-level scale of 4: a level scale of 2^74, refused at the first level beyond 2^21 vertices.
  auto scale = good;
  patch<int32_t>(scale, kAtLevels, 32);
  patch<double>(scale, kAtPerLevelScale, 4.0);
  fixChecksum(scale);
  expectRefused(scale, "level resolution too large", "per-level scale 4 over 32 levels");
  auto levels = good;
  patch<int32_t>(levels, kAtLevels, 1000);
  fixChecksum(levels);
  expectRefused(levels, "corrupt NeuralVolume model: configuration: ", "1000 levels");
  // Parameter counts that would overflow a byte count.
  for (uint64_t count : { uint64_t(1) << 63, ~uint64_t(0), uint64_t(8593) })
  {
    auto bad = good;
    patch<uint64_t>(bad, parameterCountAt(bad), count);
    fixChecksum(bad);
    expectRefused(bad, "parameters stored, the configuration needs 8592", "parameter count");
  }
  // Header sizes: beyond the bound, beyond the bytes, and not what the fields take.
  for (uint32_t headerBytes : { 0xFFFFFFF0u, 16385u, 20000u, 243u, 300u })
  {
    auto bad = good;
    patch<uint32_t>(bad, kAtHeaderBytes, headerBytes);
    fixChecksum(bad);
    expectRefused(bad, "", "header size"); // any nv::Error, within the cap
  }
  auto name = good;
  patch<uint32_t>(name, kAtNameLength, 0x7FFFFFFFu);
  fixChecksum(name);
  expectRefused(name, "array name is 2147483647 bytes long", "array name length");
}

NV_TEST(crafted_masks_are_refused_before_allocating)
{
  // A domain mask stated for a grid too large for one, and run counts beyond the bytes present: refused by
  // scanning, before the bits are allocated.
  Model m = craftedModel(Precision::Float16);
  m.source.domain.assign(size_t(domainWords(m.source.dims)), 0x0F0F0F0Fu);
  const auto v2 = serialize(m);
  const size_t countAt = parameterCountAt(v2) + 8 + 8592 * 2;
  EXPECT_TRUE(peek<uint64_t>(v2, countAt) * 4 + countAt + 8 + 4 == v2.size());
  auto big = v2;
  patch<int64_t>(big, kAtDims, 1 << 20);
  patch<int64_t>(big, kAtDims + 8, 1 << 13);
  patch<int64_t>(big, kAtDims + 16, 1);
  fixChecksum(big);
  expectRefused(big, "a domain mask over 8589934592 samples", "a domain mask over 2^33 samples");
  for (uint64_t count : { uint64_t(1) << 63, uint64_t(64 * 32 * 7 + 2), uint64_t(64 * 32 * 7 + 1), uint64_t(0) })
  {
    auto bad = v2;
    patch<uint64_t>(bad, countAt, count);
    fixChecksum(bad);
    expectRefused(bad, "", "domain run count"); // too many runs, or more than the bytes hold, or none
  }
  // A grid of 2^20 x 2^14 samples with one run of zeros as its domain: 2^34 bits is beyond a domain mask.
  Model one = craftedModel(Precision::Float16);
  one.source.domain.assign(size_t(domainWords(one.source.dims)), 0u);
  auto single = serialize(one);
  const size_t at = parameterCountAt(single) + 8 + 8592 * 2;
  EXPECT_TRUE(peek<uint64_t>(single, at) == 1);
  patch<int64_t>(single, kAtDims, int64_t(1) << 20);
  patch<int64_t>(single, kAtDims + 8, int64_t(1) << 14);
  patch<int64_t>(single, kAtDims + 16, 1);
  fixChecksum(single);
  expectRefused(single, "a domain mask over 17179869184 samples", "a 2^34-sample domain");
  // The same run count for a 2^31-sample grid is a valid mask (run lengths are 32-bit: two runs of 2^31 - 2^30):
  // inspectModel() states the 256 MiB it needs before deserialize() allocates them.
  auto valid = serialize(one);
  patch<int64_t>(valid, kAtDims, int64_t(1) << 16);
  patch<int64_t>(valid, kAtDims + 8, int64_t(1) << 15);
  patch<int64_t>(valid, kAtDims + 16, 1);
  patch<uint32_t>(valid, at + 8, 0xFFFFFFFFu); // 2^32 - 1 outside, then the rest: more than the samples
  fixChecksum(valid);
  expectRefused(valid, "the runs of the domain mask exceed its 2147483648 bits", "a run beyond the samples");
  patch<uint32_t>(valid, at + 8, 0x80000000u); // exactly the 2^31 samples
  fixChecksum(valid);
  const ModelFileInfo info = inspectModel(valid.data(), valid.size());
  EXPECT_TRUE(info.hasDomain && info.domainRuns == 1 && info.hostBytes == 8592u * 4 + (uint64_t(1) << 28));
  // Version 3 flags and an occupancy run count beyond the bytes.
  Model s = craftedModel(Precision::Float16);
  s.source.occupancy.assign(size_t(occupancyWords(s.source.dims)), 0x5u);
  s.source.background = 1.5;
  const auto v3 = serialize(s);
  const size_t flagsAt = parameterCountAt(v3) + 8 + 8592 * 2;
  for (uint32_t flags : { 0u, 1u, 4u, 0xFFFFFFFFu })
  {
    auto bad = v3;
    patch<uint32_t>(bad, flagsAt, flags);
    fixChecksum(bad);
    expectRefused(bad, "", "mask flags");
  }
  auto occ = v3;
  patch<uint64_t>(occ, flagsAt + 4, uint64_t(1) << 40);
  fixChecksum(occ);
  expectRefused(occ, "runs in the occupancy mask", "occupancy run count");
  auto trailing = v3;
  trailing.insert(trailing.end() - 4, { 1, 2, 3 });
  fixChecksum(trailing);
  expectRefused(trailing, "3 unexpected trailing bytes", "trailing bytes");
  const Model back = deserialize(v3);
  const ModelFileInfo v3info = inspectModel(v3.data(), v3.size());
  EXPECT_TRUE(back.source.occupancy == s.source.occupancy && back.source.background == 1.5);
  EXPECT_TRUE(v3info.hostBytes == 8592u * 4 + s.source.occupancy.size() * 4);
}

NV_TEST_MAIN()
