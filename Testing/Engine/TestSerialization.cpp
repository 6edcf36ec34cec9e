// Model serialization: bit-exact round trip and clear errors for bad input.
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/Macrocells.h"
#include "Core/Serialization.h"
#include "TestHarness.h"

#include <cstring>
#include <limits>
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

NV_TEST_MAIN()
