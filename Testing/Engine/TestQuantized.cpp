// Precision::Quantized8: the rANS coder (exact round trips, hostile streams), the per-level 8-bit quantiser (error
// bound, idempotence), the version-4 format (bit-identical round trip; crafted files refused before allocating, with
// the allocation tracker of CraftedModelFiles.h) and the cost of 8 bits on a trained network.
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/GridQuantizer.h"
#include "Core/RansCoder.h"
#include "Core/ResourceEstimate.h"
#include "Core/Serialization.h"
#include "SessionHelpers.h"
#include "CraftedModelFiles.h"
#include "TestHarness.h"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <random>
#include <vector>

using namespace nv;

namespace
{
std::vector<uint8_t> decodeAll(const std::vector<uint8_t>& block, uint64_t n, size_t* used = nullptr)
{
  std::vector<uint8_t> out;
  const size_t bytes = RansCoder::decode(block.data(), block.size(), n,
    [&out](const uint8_t* s, size_t count) { out.insert(out.end(), s, s + count); });
  if (used)
    *used = bytes;
  return out;
}

/// Encodes, checks the exact round trip and the block's own size report; returns the block.
std::vector<uint8_t> roundTrip(const std::vector<uint8_t>& symbols, const char* what)
{
  std::vector<uint8_t> block;
  RansCoder::encode(symbols.data(), symbols.size(), block);
  size_t used = 0;
  const std::vector<uint8_t> back = decodeAll(block, symbols.size(), &used);
  if (back != symbols)
    nvtest::fail(__FILE__, __LINE__, std::string(what) + ": decoded symbols differ");
  if (used != block.size() || RansCoder::inspect(block.data(), block.size(), symbols.size()) != block.size())
    nvtest::fail(__FILE__, __LINE__, std::string(what) + ": block size");
  std::vector<uint8_t> again;
  RansCoder::encode(symbols.data(), symbols.size(), again);
  if (again != block)
    nvtest::fail(__FILE__, __LINE__, std::string(what) + ": encoding is not deterministic");
  return block;
}

double entropyBytes(const std::vector<uint8_t>& symbols)
{
  double counts[256] = {};
  for (uint8_t s : symbols)
    counts[s] += 1.0;
  double bits = 0.0;
  for (double c : counts)
    if (c > 0)
      bits -= c * std::log2(c / double(symbols.size()));
  return bits / 8.0;
}

/// A smooth field with a sphere: the kind of volume the network fits well.
std::vector<float> smoothField(int n)
{
  return nvtest::sampledCube(n, [](double X, double Y, double Z) {
    const double r2 = (X - .4) * (X - .4) + (Y - .55) * (Y - .55) + (Z - .5) * (Z - .5);
    return 50.0 * std::sin(5 * X) * std::cos(4 * Y) + 30.0 * std::sin(6 * Z) + (r2 < 0.06 ? 40.0 : 0.0);
  });
}


bool sameBits(const std::vector<float>& a, const std::vector<float>& b)
{
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

/// A model of 16 levels x 2 features, 2^12 table, with normal-distributed parameters of a different scale per level.
Model randomModel(uint64_t seed)
{
  ModelConfig c;
  c.encoding.levels = 16;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = 12;
  c.encoding.finestResolution = 256;
  c.network.width = 32;
  c.network.hiddenLayers = 2;
  Model m(c);
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::normal_distribution<float> g(0.f, 1.f);
  const GridLayout& lay = m.layout();
  for (int l = 0; l < lay.levels; ++l)
    for (size_t i = 0; i < size_t(lay.level[l].entries) * lay.features; ++i)
      m.params()[size_t(lay.level[l].offset) * lay.features + i] = g(rng) * 0.01f * float(l + 1);
  for (size_t i = m.encodingParamCount(); i < m.paramCount(); ++i)
    m.params()[i] = g(rng) * 0.2f;
  m.source.dims[0] = m.source.dims[1] = m.source.dims[2] = 64;
  for (int a = 0; a < 3; ++a)
    m.source.bounds[2 * a + 1] = 63;
  m.source.rawBytes = 64 * 64 * 64 * 4;
  return m;
}
} // namespace

NV_TEST(coder_round_trips_exactly)
{
  std::mt19937 rng(3);
  std::vector<uint8_t> random(200000);
  for (uint8_t& s : random)
    s = uint8_t(rng());
  const auto r = roundTrip(random, "uniform random");
  // Uniform bytes do not compress: at most the table (256 x 2-byte frequencies), the length and the state more.
  EXPECT_TRUE(r.size() <= random.size() + 1 + 512 + 8 + 4 + random.size() / 400);

  const auto constant = roundTrip(std::vector<uint8_t>(100000, 77), "constant");
  // Table of 78 frequencies (77 zeros of 1 byte, one of 3), length, state, padding to 100000/1024 bytes.
  EXPECT_TRUE(constant.size() == 1 + 77 + 3 + 4 + RansCoder::minStreamBytes(100000));
  roundTrip(std::vector<uint8_t>(1, 255), "one symbol 255");
  roundTrip(std::vector<uint8_t>(5000, 0), "single symbol 0");
  EXPECT_TRUE(roundTrip(std::vector<uint8_t>(), "empty").size() == 1 + 3 + 4 + 4);

  // Skewed (two-sided geometric, as hash-table codes are): within 1% + 600 bytes of the order-0 entropy.
  std::geometric_distribution<int> geo(0.35);
  std::vector<uint8_t> skewed(300000);
  for (uint8_t& s : skewed)
    s = uint8_t(std::min(254, geo(rng)));
  const auto k = roundTrip(skewed, "skewed");
  const double h = entropyBytes(skewed);
  std::printf("  skewed: %zu symbols, %zu bytes coded, entropy %.0f bytes\n", skewed.size(), k.size(), h);
  EXPECT_TRUE(double(k.size()) <= 1.01 * h + 600.0 && double(k.size()) >= h);

  // Every symbol, including rare ones next to a dominant one (frequency 1 of 2^15).
  std::vector<uint8_t> rare(70000, 5);
  for (int s = 0; s < 256; ++s)
    rare[size_t(s) * 17] = uint8_t(s);
  roundTrip(rare, "rare symbols");
}

NV_TEST(coder_refuses_corrupt_and_truncated_streams)
{
  std::geometric_distribution<int> geo(0.3);
  std::mt19937 rng(5);
  std::vector<uint8_t> symbols(3000);
  for (uint8_t& s : symbols)
    s = uint8_t(std::min(254, geo(rng)));
  std::vector<uint8_t> block;
  RansCoder::encode(symbols.data(), symbols.size(), block);
  // Every truncation is refused (by inspect and by decode).
  for (size_t len = 0; len < block.size(); ++len)
  {
    const std::vector<uint8_t> cut(block.begin(), block.begin() + long(len));
    EXPECT_THROW_MSG(RansCoder::inspect(cut.data(), cut.size(), symbols.size()), "corrupt entropy-coded stream");
    EXPECT_THROW_MSG(decodeAll(cut, symbols.size()), "corrupt entropy-coded stream");
  }
  // Every single-bit change of the stream is detected (final state and padding checks); a change of the table
  // either is refused or decodes other symbols that the state check refuses: never a crash, always nv::Error.
  int refused = 0, changes = 0;
  for (size_t at = 0; at < block.size(); ++at)
    for (int bit = 0; bit < 8; ++bit)
    {
      std::vector<uint8_t> bad = block;
      bad[at] ^= uint8_t(1u << bit);
      ++changes;
      try
      {
        if (decodeAll(bad, symbols.size()) != symbols)
          nvtest::fail(__FILE__, __LINE__, "a changed block decoded to other symbols without an error");
      }
      catch (const Error&)
      {
        ++refused;
      }
    }
  std::printf("  %d of %d single-bit changes refused\n", refused, changes);
  EXPECT_TRUE(refused == changes);
  // A wrong symbol count: the state check (or the stream's end) refuses it.
  EXPECT_THROW_MSG(decodeAll(block, symbols.size() - 1), "corrupt entropy-coded stream");
  EXPECT_THROW_MSG(decodeAll(block, symbols.size() + 1), "corrupt entropy-coded stream");
  // Hostile tables: a sum off by one, a zero last frequency, an overlong varint, a huge count for a short stream.
  const std::vector<uint8_t> sumOff = { 1, 0x80, 0x80, 0x02, 0x01, 4, 0, 0, 0, 0, 0, 0x80, 0 };
  EXPECT_THROW_MSG(RansCoder::inspect(sumOff.data(), sumOff.size(), 1), "frequencies sum to 32769");
  const std::vector<uint8_t> zeroLast = { 1, 0x80, 0x80, 0x02, 0, 4, 0, 0, 0, 0, 0, 0x80, 0 };
  EXPECT_THROW_MSG(RansCoder::inspect(zeroLast.data(), zeroLast.size(), 1), "last symbol has frequency 0");
  const std::vector<uint8_t> overlong = { 0, 0x80, 0x80, 0x80, 0x80, 0x01 };
  EXPECT_THROW_MSG(RansCoder::inspect(overlong.data(), overlong.size(), 1), "more than 3 bytes");
  const std::vector<uint8_t> single = { 0, 0x80, 0x80, 0x02, 4, 0, 0, 0, 0, 0, 0x80, 0 };
  EXPECT_TRUE(decodeAll(single, 1023) == std::vector<uint8_t>(1023, 0)); // a 4-byte stream holds up to 1023
  EXPECT_THROW_MSG(RansCoder::inspect(single.data(), single.size(), uint64_t(1) << 40), "at least");
  EXPECT_THROW_MSG(RansCoder::inspect(single.data(), single.size(), 1024), "at least 5");
  std::vector<uint8_t> badState = single;
  badState[10] = 0; // state 0: below the encoder's range
  EXPECT_THROW_MSG(decodeAll(badState, 1), "initial state");
}

NV_TEST(quantisation_error_is_bounded_by_half_a_step)
{
  Model m = randomModel(11);
  const Model original = m;
  m.quantize(Precision::Quantized8);
  const GridLayout& g = m.layout();
  EXPECT_TRUE(int(m.levelSteps().size()) == g.levels);
  int clippedLevels = 0;
  for (int l = 0; l < g.levels; ++l)
  {
    const float step = m.levelSteps()[size_t(l)];
    const size_t at = size_t(g.level[l].offset) * g.features, n = size_t(g.level[l].entries) * g.features;
    const float* w = original.params().data() + at;
    const float* q = m.params().data() + at;
    EXPECT_TRUE(step > 0.0f && GridQuantizer::validStep(step));
    double worst = 0.0;
    bool clipped = false;
    for (size_t i = 0; i < n; ++i)
    {
      if (std::fabs(w[i]) <= 127.0 * step)
        worst = std::max(worst, std::fabs(double(w[i]) - double(q[i])) / step);
      else
      {
        clipped = true;
        if (std::fabs(q[i]) != 127.0f * step || (q[i] > 0) != (w[i] > 0))
          nvtest::fail(__FILE__, __LINE__, "a clipped entry is not +-127 steps");
      }
    }
    clippedLevels += clipped;
    if (worst > 0.5 + 1e-6)
      nvtest::fail(__FILE__, __LINE__, "level " + std::to_string(l) + ": error " + std::to_string(worst) + " steps");
    // The chosen step is no worse than the unclipped one (max|w| / 127).
    float top = 0.0f;
    for (size_t i = 0; i < n; ++i)
      top = std::max(top, std::fabs(w[i]));
    EXPECT_TRUE(GridQuantizer::squaredError(w, n, step) <= GridQuantizer::squaredError(w, n, top / 127.0f));
  }
  std::printf("  %d of %d levels clip their largest entries\n", clippedLevels, g.levels);
  EXPECT_TRUE(clippedLevels > 0); // normal values: clipping a few outliers lowers the error
  // The MLP is stored as fp16.
  for (size_t i = m.encodingParamCount(); i < m.paramCount(); ++i)
    if (m.params()[i] != halfToFloat(floatToHalf(original.params()[i])))
    {
      nvtest::fail(__FILE__, __LINE__, "MLP weight not fp16");
      break;
    }
  // Non-finite entries: NaN codes as 0, Inf as the clip; the step ignores them.
  Model odd = randomModel(12);
  odd.params()[3] = std::nanf("");
  odd.params()[5] = INFINITY;
  odd.quantize(Precision::Quantized8);
  EXPECT_TRUE(odd.params()[3] == 0.0f && odd.params()[5] == 127.0f * odd.levelSteps()[0]);
  // An all-zero level gets step 0.
  Model zero(randomModel(1).config());
  zero.quantize(Precision::Quantized8);
  EXPECT_TRUE(zero.levelSteps()[0] == 0.0f && zero.params()[0] == 0.0f);
}

NV_TEST(quantising_twice_changes_nothing)
{
  Model m = randomModel(21);
  m.quantize(Precision::Quantized8);
  Model again = m;
  again.quantize(Precision::Quantized8);
  EXPECT_TRUE(sameBits(m.params(), again.params()));
  EXPECT_TRUE(m.levelSteps() == again.levelSteps() && m.parameterBytes() == again.parameterBytes());
  // Deserialized, then quantised again (what the filter does with a restored network): unchanged.
  Model back = deserialize(serialize(m));
  back.quantize(Precision::Quantized8);
  EXPECT_TRUE(sameBits(m.params(), back.params()) && back.levelSteps() == m.levelSteps());
  // Parameters moved after quantising (training went on): new steps, then stable.
  Model moved = m;
  for (size_t i = 0; i < moved.encodingParamCount(); i += 7)
    moved.params()[i] *= 1.37f;
  moved.quantize(Precision::Quantized8);
  Model moved2 = moved;
  moved2.quantize(Precision::Quantized8);
  EXPECT_TRUE(moved.levelSteps() != m.levelSteps() && sameBits(moved.params(), moved2.params()));
  // Back to fp16 or fp32: the quantised state goes.
  moved2.quantize(Precision::Float16);
  EXPECT_TRUE(moved2.levelSteps().empty() && moved2.parameterBytes() == int64_t(moved2.paramCount()) * 2);
}

NV_TEST(version_4_round_trip_is_bit_identical)
{
  Model m = randomModel(31);
  m.source.arrayName = "q";
  m.stats.steps = 99;
  m.quantize(Precision::Quantized8);
  const std::vector<uint8_t> bytes = serialize(m);
  uint32_t version;
  std::memcpy(&version, bytes.data() + 8, 4);
  EXPECT_TRUE(version == kFormatVersionQuantized);
  const ModelFileInfo info = inspectModel(bytes.data(), bytes.size());
  EXPECT_TRUE(info.precision == Precision::Quantized8 && int64_t(info.parameterBytes) == m.parameterBytes());
  EXPECT_TRUE(info.hostBytes == uint64_t(m.paramCount()) * 4 && !info.hasDomain && !info.hasOccupancy);
  const Model back = deserialize(bytes);
  EXPECT_TRUE(back.storagePrecision() == Precision::Quantized8);
  EXPECT_TRUE(sameBits(m.params(), back.params()));
  EXPECT_TRUE(back.levelSteps() == m.levelSteps() && back.parameterBytes() == m.parameterBytes());
  EXPECT_TRUE(serialize(back) == bytes);
  // The file is the header, the coded block, counts, flags and checksum: parameterBytes() is what it holds.
  EXPECT_TRUE(int64_t(bytes.size()) - m.parameterBytes() < 400);
  const int64_t fp16 = int64_t(m.paramCount()) * 2;
  std::printf("  random normal parameters: %lld bytes coded, %lld as fp16 (%.2fx)\n",
    (long long)m.parameterBytes(), (long long)fp16, double(fp16) / double(m.parameterBytes()));
  EXPECT_TRUE(double(fp16) / double(m.parameterBytes()) > 2.0); // measured 2.11 (about 7.4 bits per code)
  // With both masks (flags 3 in version 4).
  Model masked = m;
  masked.source.domain.assign(size_t(domainWords(masked.source.dims)), 0xF0F0F0F0u);
  masked.source.occupancy.assign(size_t(occupancyWords(masked.source.dims)), 0u);
  masked.source.occupancy[0] = 5u;
  const Model maskedBack = deserialize(serialize(masked));
  EXPECT_TRUE(sameBits(maskedBack.params(), m.params()) && maskedBack.source.domain == masked.source.domain &&
    maskedBack.source.occupancy == masked.source.occupancy);
  // A corrupt coded stream inside a file whose checksum matches: nv::Error naming the level.
  std::vector<uint8_t> bad = bytes;
  const size_t streamAt = info.parametersAt + 4 + 40; // inside level 0's table or stream
  bad[streamAt] ^= 0x10u;
  fixChecksum(bad);
  EXPECT_THROW_MSG(deserialize(bad), "corrupt NeuralVolume model: quantised parameters: level 0");
  // Version 4 holds Quantized8 only; Quantized8 is version 4 only.
  std::vector<uint8_t> wrongVersion = bytes;
  wrongVersion[8] = 3;
  fixChecksum(wrongVersion);
  EXPECT_THROW_MSG(deserialize(wrongVersion), "parameter precision 2 in version 3");
}

// ---- Crafted version-4 files (CraftedModelFiles.h: offsets of the format, the allocation tracker).

NV_TEST(crafted_quantized_files_are_refused_before_allocating)
{
  // Version 4 (Quantized8): the coded block's steps, coder tables and stream lengths are checked against the bytes
  // present (a stream holds at least one byte per 1024 codes), before the parameters are allocated.
  Model m = craftedModel(Precision::Quantized8);
  const auto v4 = serialize(m);
  const size_t blockBytesAt = parameterCountAt(v4) + 8, blockAt = blockBytesAt + 8;
  EXPECT_TRUE(peek<uint32_t>(v4, kAtVersion) == 4 && peek<int32_t>(v4, kAtPrecision) == 2);
  EXPECT_TRUE(int64_t(peek<uint64_t>(v4, blockBytesAt)) == m.parameterBytes());
  EXPECT_TRUE(peek<float>(v4, blockAt) == m.levelSteps()[0]);
  EXPECT_TRUE(v4.size() < 12000); // 17 KB in fp16; uniform initial values take 8 bits a code, tables 0.5 KB a level
  // A 2^23 table over 16 levels of 8 features (2^30 parameters, 4.3 GB as fp32) with its count: the block of four
  // small levels cannot hold it.
  auto huge = v4;
  patch<int32_t>(huge, kAtLevels, 16);
  patch<int32_t>(huge, kAtFeatures, 8);
  patch<int32_t>(huge, kAtLog2Table, 23);
  patch<int32_t>(huge, kAtFinest, 4096);
  ModelConfig big = m.config();
  big.encoding.levels = 16;
  big.encoding.featuresPerLevel = 8;
  big.encoding.log2TableSize = 23;
  big.encoding.finestResolution = 4096;
  const uint64_t needed = uint64_t(parameterCount(big));
  EXPECT_TRUE(needed > (uint64_t(1) << 29));
  patch<uint64_t>(huge, parameterCountAt(huge), needed);
  fixChecksum(huge);
  expectRefused(huge, "corrupt NeuralVolume model: quantised parameters: level ", "a huge quantised table");
  // Block sizes beyond the file, or other than what the block takes.
  for (uint64_t bytes : { ~uint64_t(0), uint64_t(1) << 40, uint64_t(v4.size()), uint64_t(m.parameterBytes() - 1) })
  {
    auto bad = v4;
    patch<uint64_t>(bad, blockBytesAt, bytes);
    fixChecksum(bad);
    expectRefused(bad, "", "quantised block bytes");
  }
  // Steps that cannot be stored: NaN, Inf, negative, subnormal, so large that 127 steps overflow.
  for (float step : { std::nanf(""), INFINITY, -1.0f, 1e-40f, 3e38f })
  {
    auto bad = v4;
    patch<float>(bad, blockAt, step);
    fixChecksum(bad);
    expectRefused(bad, "level 0 has step", "quantisation step");
  }
  // A symbol count making the frequency table too long, and a stream length beyond the block.
  auto table = v4;
  patch<uint8_t>(table, blockAt + 4, 255);
  fixChecksum(table);
  expectRefused(table, "level 0", "symbol count");
  // Precision and version must agree both ways.
  auto precision = v4;
  patch<int32_t>(precision, kAtPrecision, 1);
  fixChecksum(precision);
  expectRefused(precision, "parameter precision 1 in version 4", "fp16 in version 4");
  Model half = craftedModel(Precision::Quantized8);
  half.quantize(Precision::Float16);
  auto fp16 = serialize(half);
  patch<int32_t>(fp16, kAtPrecision, 2);
  fixChecksum(fp16);
  expectRefused(fp16, "parameter precision 2 in version 1", "q8 in version 1");
  patch<int32_t>(fp16, kAtPrecision, 3);
  fixChecksum(fp16);
  expectRefused(fp16, "unknown parameter precision 3", "precision 3");
  // Mask flags of version 4: 0 to 3.
  auto flags = v4;
  patch<uint32_t>(flags, blockAt + size_t(m.parameterBytes()), 4u);
  fixChecksum(flags);
  expectRefused(flags, "mask flags 4 in version 4", "version 4 flags");
  const ModelFileInfo info = inspectModel(v4.data(), v4.size());
  EXPECT_TRUE(info.hostBytes == 8592u * 4 && info.parametersAt == blockAt);
}

NV_TEST(trained_network_costs_little_psnr_for_a_much_smaller_model)
{
  const int n = 32;
  const std::vector<float> field = smoothField(n);
  const VolumeView vol = nvtest::cubeView(field, n);
  ModelConfig c;
  c.encoding.levels = 16;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = 12;
  c.encoding.finestResolution = 64;
  c.network.width = 32;
  c.network.hiddenLayers = 2;
  Model m = nvtest::untrainedModel(c, vol, 5);
  m.source.dims[0] = m.source.dims[1] = m.source.dims[2] = n;
  for (int a = 0; a < 3; ++a)
    m.source.bounds[2 * a + 1] = n - 1;
  TrainConfig tc;
  tc.batchSize = 8192;
  tc.seed = 5;
  tc.threads = 2;
  tc.optimizer.schedule = LearningRateSchedule::Cosine;
  tc.optimizer.plannedSteps = 400;
  auto tr = nvtest::createTrainer(Device::Cpu, m, vol, tc);
  for (int i = 0; i < 400; ++i)
    tr->step();
  tr->syncTo(m);
  Model fp16 = m, q8 = m;
  fp16.quantize(Precision::Float16);
  q8.quantize(Precision::Quantized8);
  const ErrorStats e16 = nvtest::compareToSource(fp16, vol, Device::Cpu, 2);
  const ErrorStats e8 = nvtest::compareToSource(q8, vol, Device::Cpu, 2);
  // The stored network is what decodes: the same PSNR after a file round trip.
  const ErrorStats eFile = nvtest::compareToSource(deserialize(serialize(q8)), vol, Device::Cpu, 2);
  const double factor = double(fp16.parameterBytes()) / double(q8.parameterBytes());
  std::printf("  32^3 smooth field, 400 steps: fp16 %.2f dB %lld bytes, q8 %.2f dB %lld bytes (%.2fx smaller)\n",
    e16.psnr, (long long)fp16.parameterBytes(), e8.psnr, (long long)q8.parameterBytes(), factor);
  EXPECT_TRUE(e16.psnr > 35.0);
  // Measured: 38.52 / 38.49 dB, 2.40x (8-bit codes at the error-minimising step take about 6.5 bits each).
  EXPECT_TRUE(e8.psnr > e16.psnr - 0.25);
  EXPECT_TRUE(eFile.psnr == e8.psnr && eFile.maxAbsError == e8.maxAbsError);
  EXPECT_TRUE(factor > 2.2);
}

NV_TEST(table_size_from_target_ratio_counts_a_byte_per_code)
{
  ModelConfig c; // 16 x 4 levels, finest 512, 64 x 4 MLP: the figures of TestTraining's table_size_from_target_ratio
  c.encoding.finestResolution = 512;
  const int64_t raw = int64_t(128) * 128 * 256 * 2; // stent int16
  const int fp16 = chooseLog2TableSize(c, raw, 4.0, Precision::Float16);
  const int q8 = chooseLog2TableSize(c, raw, 4.0, Precision::Quantized8);
  // 2^15: 1,495,232 table features at 1 byte + 16,448 MLP weights at 2 = 1.53 MB -> 5.5:1; 2^16 would be 3.2:1.
  EXPECT_TRUE(fp16 == 14 && q8 == 15);
  c.encoding.log2TableSize = q8 + 1;
  const Model bigger(c);
  EXPECT_TRUE(double(raw) / (double(bigger.encodingParamCount()) + 2.0 * double(bigger.mlpParamCount())) < 4.0);
}

NV_TEST(automatic_size_fits_the_data_folder_volumes)
{
  // Neural Compress's defaults (16 x 4 levels, finest twice the largest dimension, 64 x 4 MLP, target 10:1).
  auto configFor = [](int64_t largest) {
    ModelConfig c;
    c.encoding.finestResolution = int(2 * largest);
    return c;
  };
  auto automatic = [&](int64_t largest, int64_t raw, bool defaultTarget, bool autoStorage, Precision storage) {
    return chooseAutomaticSize(configFor(largest), raw, 10.0, defaultTarget, autoStorage, storage);
  };
  // walnut 128 x 96 x 114 uint16: 2^10 in fp16 (17.1:1; 2^11 would be 9.5:1), 2^11 in 8-bit codes (estimated 17.1:1,
  // coded 18.6:1).
  const int64_t walnutRaw = int64_t(128) * 96 * 114 * 2;
  const AutomaticSize walnut = automatic(128, walnutRaw, true, true, Precision::Float16);
  EXPECT_TRUE(walnut.log2TableSize == 11 && walnut.storage == Precision::Quantized8 && walnut.targetReached);
  const AutomaticSize walnut16 = automatic(128, walnutRaw, true, false, Precision::Float16);
  EXPECT_TRUE(walnut16.log2TableSize == 10 && walnut16.storage == Precision::Float16 && walnut16.targetReached);
  // stent 128 x 128 x 256 int16: 2^12 fp16, 2^13 8-bit.
  const AutomaticSize stent = automatic(256, int64_t(128) * 128 * 256 * 2, true, true, Precision::Float16);
  EXPECT_TRUE(stent.log2TableSize == 13 && stent.storage == Precision::Quantized8 && stent.targetReached);
  // headsq 64 x 64 x 93 int16: no table reaches 10:1; the largest that still compresses: 2^13 in 8-bit (1.42:1
  // estimated), 2^12 in fp16 (1.37:1).
  const int64_t headsq = int64_t(64) * 64 * 93 * 2;
  const AutomaticSize small = automatic(93, headsq, true, true, Precision::Float16);
  EXPECT_TRUE(small.log2TableSize == 13 && small.storage == Precision::Quantized8 && !small.targetReached);
  EXPECT_TRUE(automatic(93, headsq, true, false, Precision::Float16).log2TableSize == 12);
  // nucleon 41^3 uint8: even the smallest model is larger than the field: the smallest table.
  const AutomaticSize nucleon = automatic(41, int64_t(41) * 41 * 41, true, true, Precision::Float16);
  EXPECT_TRUE(nucleon.log2TableSize == 10 && !nucleon.targetReached);
  // An explicit target out of reach keeps the smallest table in the storage set (the filter warns).
  const AutomaticSize asked = automatic(93, headsq, false, false, Precision::Quantized8);
  EXPECT_TRUE(asked.log2TableSize == 10 && asked.storage == Precision::Quantized8 && !asked.targetReached);
}

NV_TEST_MAIN()
