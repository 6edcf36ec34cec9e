#include "Model.h"

#include "DomainMask.h"
#include "Macrocells.h"
#include "Error.h"
#include "GridQuantizer.h"
#include "QuantizedParameters.h"

#include <cmath>
#include <cstring>

namespace nv
{

GridLayout makeGridLayout(const EncodingConfig& e)
{
  ModelConfig probe;
  probe.encoding = e;
  validate(probe);
  GridLayout g{};
  g.levels = e.levels;
  g.features = e.featuresPerLevel;
  const float log2Scale = std::log2(static_cast<float>(e.effectivePerLevelScale()));
  const uint64_t tableSize = 1ull << e.log2TableSize;
  uint64_t offset = 0;
  for (int l = 0; l < e.levels; ++l)
  {
    LevelInfo& lv = g.level[l];
    lv.scale = std::exp2(static_cast<float>(l) * log2Scale) * static_cast<float>(e.baseResolution) - 1.0f;
    const uint64_t res = static_cast<uint64_t>(std::ceil(lv.scale)) + 1;
    NV_CHECK(res <= (1u << 21), "level resolution too large");
    const uint64_t dense = res * res * res;
    const uint64_t rounded = (dense + 7) / 8 * 8;
    lv.res = static_cast<uint32_t>(res);
    lv.entries = static_cast<uint32_t>(rounded < tableSize ? rounded : tableSize);
    // Dense indexing needs res^3 to fit in 32 bits as well as in the table.
    lv.hashed = (lv.entries < dense || res > 1625) ? 1u : 0u;
    if (lv.hashed)
    {
      lv.entries = static_cast<uint32_t>(tableSize);
    }
    lv.offset = static_cast<uint32_t>(offset);
    offset += lv.entries;
    NV_CHECK(offset * e.featuresPerLevel < (1ull << 31), "hash table too large (more than 2^31 parameters)");
  }
  g.totalEntries = static_cast<uint32_t>(offset);
  return g;
}

Model::Model(const ModelConfig& config)
  : Config(config)
{
  validate(config);
  Layout = makeGridLayout(config.encoding);
  Params.assign(encodingParamCount() + mlpParamCount(), 0.0f);
}

size_t mlpParameterCount(const ModelConfig& config)
{
  size_t n = 0;
  for (int l = 0; l <= config.network.hiddenLayers; ++l)
  {
    const size_t in = l == 0 ? static_cast<size_t>(config.encoding.outputDims()) : size_t(config.network.width);
    const size_t out = l == config.network.hiddenLayers ? 1 : size_t(config.network.width);
    n += in * out;
  }
  return n;
}

size_t Model::mlpParamCount() const
{
  return mlpParameterCount(Config);
}

int Model::layerInputs(int l) const
{
  return l == 0 ? Config.encoding.outputDims() : Config.network.width;
}

int Model::layerOutputs(int l) const
{
  return l == Config.network.hiddenLayers ? 1 : Config.network.width;
}

size_t Model::layerOffset(int l) const
{
  size_t off = encodingParamCount();
  for (int k = 0; k < l; ++k)
  {
    off += static_cast<size_t>(layerInputs(k)) * layerOutputs(k);
  }
  return off;
}

namespace
{
float uniform(uint64_t seed, uint64_t i, float lo, float hi)
{
  const uint64_t r = mix64(seed * 0x9E3779B97F4A7C15ull ^ mix64(i));
  const float u = static_cast<float>(r >> 40) / 16777216.0f;
  return lo + (hi - lo) * u;
}
} // namespace

void Model::initialize(uint64_t seed)
{
  const size_t ne = encodingParamCount();
  for (size_t i = 0; i < ne; ++i)
  {
    Params[i] = uniform(seed, i, -1e-4f, 1e-4f);
  }
  for (int l = 0; l <= Config.network.hiddenLayers; ++l)
  {
    const float bound = 1.0f / std::sqrt(static_cast<float>(layerInputs(l)));
    const size_t off = layerOffset(l);
    const size_t n = static_cast<size_t>(layerInputs(l)) * layerOutputs(l);
    for (size_t i = 0; i < n; ++i)
    {
      Params[off + i] = uniform(seed + 0x5bd1e995ull * (l + 1), i, -bound, bound);
    }
  }
  Storage = Precision::Float32;
  clearQuantizedState();
}

const char* precisionName(Precision p)
{
  return p == Precision::Float16 ? "fp16" : p == Precision::Quantized8 ? "q8" : "fp32";
}

void Model::quantize(Precision p)
{
  NV_CHECK(p == Precision::Float32 || p == Precision::Float16 || p == Precision::Quantized8,
    "unknown storage precision " + std::to_string(int(p)));
  if (p == Precision::Quantized8 && codedParameters())
  {
    return; // quantised already, and unchanged since
  }
  const bool wasQuantized = Storage == Precision::Quantized8 && int(LevelSteps.size()) == Layout.levels;
  Storage = p;
  if (p == Precision::Float16)
  {
    for (float& v : Params)
    {
      v = halfToFloat(floatToHalf(v));
    }
  }
  if (p != Precision::Quantized8)
  {
    clearQuantizedState();
    return;
  }
  std::vector<float> steps(size_t(Layout.levels));
  for (int l = 0; l < Layout.levels; ++l)
  {
    float* w = Params.data() + size_t(Layout.level[l].offset) * Layout.features;
    const size_t n = size_t(Layout.level[l].entries) * Layout.features;
    const float old = wasQuantized ? LevelSteps[size_t(l)] : 0.0f;
    const float step = wasQuantized && GridQuantizer::onGrid(w, n, old) ? old : GridQuantizer::chooseStep(w, n);
    steps[size_t(l)] = step;
    for (size_t i = 0; i < n; ++i)
    {
      w[i] = GridQuantizer::value(GridQuantizer::code(w[i], step), step);
    }
  }
  for (size_t i = encodingParamCount(); i < Params.size(); ++i)
  {
    Params[i] = halfToFloat(floatToHalf(Params[i]));
  }
  LevelSteps = std::move(steps);
  CodedBlock.reset();
  auto block = std::make_shared<const std::vector<uint8_t>>(encodeQuantizedParameters(*this));
  CodedBytes = static_cast<int64_t>(block->size());
  CodedFingerprint = fingerprint();
  CodedBlock = std::move(block);
}

void Model::clearQuantizedState()
{
  LevelSteps.clear();
  CodedBytes = 0;
  CodedBlock.reset();
  CodedFingerprint = 0;
}

uint64_t Model::fingerprint() const
{
  // Four independent multiply-xor lanes over the parameters' and steps' bits (memory bound: about 10 ms for 2^24
  // parameters).
  uint64_t lane[4] = { 0x9E3779B97F4A7C15ull, 0xC2B2AE3D27D4EB4Full, 0x165667B19E3779F9ull, 0x27D4EB2F165667C5ull };
  const size_t words = Params.size() / 2;
  const uint8_t* bytes = reinterpret_cast<const uint8_t*>(Params.data());
  size_t i = 0;
  for (; i + 4 <= words; i += 4)
    for (int k = 0; k < 4; ++k)
    {
      uint64_t w;
      std::memcpy(&w, bytes + 8 * (i + size_t(k)), 8);
      lane[k] = (lane[k] ^ w) * 0x100000001B3ull;
    }
  uint64_t h = Params.size();
  for (int k = 0; k < 4; ++k)
    h = mix64(h ^ lane[k]);
  for (size_t j = 8 * i; j < Params.size() * 4; ++j)
    h = mix64(h ^ bytes[j]);
  for (float s : LevelSteps)
  {
    uint32_t b;
    std::memcpy(&b, &s, 4);
    h = mix64(h ^ b);
  }
  return h;
}

const std::vector<uint8_t>* Model::codedParameters() const
{
  if (Storage != Precision::Quantized8 || !CodedBlock || fingerprint() != CodedFingerprint)
    return nullptr;
  return CodedBlock.get();
}

void Model::setStoragePrecision(Precision p)
{
  NV_CHECK(p == Precision::Float32 || p == Precision::Float16,
    "setStoragePrecision() records fp32 or fp16 parameters (Quantized8: setQuantizedState())");
  Storage = p;
  clearQuantizedState();
}

void Model::setQuantizedState(std::vector<float> levelSteps, int64_t codedBytes)
{
  NV_CHECK(int(levelSteps.size()) == Layout.levels, "one quantisation step per level");
  NV_CHECK(codedBytes > 0, "coded parameter bytes");
  clearQuantizedState();
  Storage = Precision::Quantized8;
  LevelSteps = std::move(levelSteps);
  CodedBytes = codedBytes;
}

int64_t Model::parameterBytes() const
{
  if (Storage == Precision::Quantized8)
  {
    return CodedBytes;
  }
  return static_cast<int64_t>(Params.size()) * (Storage == Precision::Float16 ? 2 : 4);
}

double estimatedRatio(const ModelConfig& config, int64_t rawBytes, Precision storage)
{
  const GridLayout g = makeGridLayout(config.encoding);
  const double mlp = static_cast<double>(mlpParameterCount(config));
  const double table = static_cast<double>(g.totalEntries) * g.features;
  const double bytes = storage == Precision::Quantized8 ? table + 2.0 * mlp
                                                        : (table + mlp) * (storage == Precision::Float16 ? 2.0 : 4.0);
  return static_cast<double>(rawBytes) / bytes;
}

int chooseLog2TableSize(ModelConfig config, int64_t rawBytes, double targetRatio, Precision storage, int minLog2,
  int maxLog2)
{
  NV_CHECK(targetRatio > 0.0, "target compression ratio must be > 0");
  int best = minLog2;
  for (int l = minLog2; l <= maxLog2; ++l)
  {
    config.encoding.log2TableSize = l;
    if (estimatedRatio(config, rawBytes, storage) < targetRatio)
      break;
    best = l;
  }
  return best;
}

AutomaticSize chooseAutomaticSize(const ModelConfig& config, int64_t rawBytes, double targetRatio,
  bool targetIsDefault, bool automaticStorage, Precision storage)
{
  NV_CHECK(targetRatio > 0.0 && std::isfinite(targetRatio), "target compression ratio must be > 0");
  AutomaticSize size;
  size.storage = automaticStorage ? Precision::Quantized8 : storage;
  size.log2TableSize = chooseLog2TableSize(config, rawBytes, targetRatio, size.storage);
  ModelConfig chosen = config;
  chosen.encoding.log2TableSize = size.log2TableSize;
  size.targetReached = estimatedRatio(chosen, rawBytes, size.storage) >= targetRatio;
  if (!size.targetReached && targetIsDefault)
    size.log2TableSize = chooseLog2TableSize(config, rawBytes, 1.0, size.storage); // the largest that compresses
  return size;
}

uint16_t floatToHalf(float f)
{
  uint32_t x;
  std::memcpy(&x, &f, 4);
  const uint32_t sign = (x >> 16) & 0x8000u;
  const uint32_t absx = x & 0x7FFFFFFFu;
  if (absx >= 0x7F800000u)
  {
    return static_cast<uint16_t>(sign | 0x7C00u | (absx > 0x7F800000u ? 0x200u : 0u));
  }
  if (absx >= 0x477FF000u) // rounds to >= 65520: overflow to infinity
  {
    return static_cast<uint16_t>(sign | 0x7C00u);
  }
  if (absx < 0x38800000u) // subnormal half (or zero)
  {
    if (absx < 0x33000000u)
    {
      return static_cast<uint16_t>(sign);
    }
    const uint32_t e = absx >> 23;
    const uint32_t m = (absx & 0x7FFFFFu) | 0x800000u;
    const uint32_t shift = 126 - e; // 14..24
    uint32_t h = m >> shift;
    const uint32_t rem = m & ((1u << shift) - 1u);
    const uint32_t half = 1u << (shift - 1);
    if (rem > half || (rem == half && (h & 1u)))
    {
      ++h;
    }
    return static_cast<uint16_t>(sign | h);
  }
  uint32_t h = ((absx - 0x38000000u) >> 13);
  const uint32_t rem = absx & 0x1FFFu;
  if (rem > 0x1000u || (rem == 0x1000u && (h & 1u)))
  {
    ++h;
  }
  return static_cast<uint16_t>(sign | h);
}

float halfToFloat(uint16_t h)
{
  const uint32_t sign = (static_cast<uint32_t>(h) & 0x8000u) << 16;
  const uint32_t e = (h >> 10) & 0x1Fu;
  uint32_t m = h & 0x3FFu;
  uint32_t x;
  if (e == 0)
  {
    if (m == 0)
    {
      x = sign;
    }
    else
    {
      int shift = 0;
      while (!(m & 0x400u))
      {
        m <<= 1;
        ++shift;
      }
      m &= 0x3FFu;
      x = sign | (static_cast<uint32_t>(113 - shift) << 23) | (m << 13);
    }
  }
  else if (e == 31)
  {
    x = sign | 0x7F800000u | (m << 13);
  }
  else
  {
    x = sign | ((e + 112) << 23) | (m << 13);
  }
  float f;
  std::memcpy(&f, &x, 4);
  return f;
}

} // namespace nv

namespace nv
{
int64_t occupancyWords(const int64_t dims[3])
{
  const MacrocellLayout m = macrocellLayout(dims);
  return (int64_t(m.dims[0]) * m.dims[1] * m.dims[2] + 31) / 32;
}

int64_t domainWords(const int64_t dims[3])
{
  return (dims[0] * dims[1] * dims[2] + 31) / 32;
}

void validate(const SourceInfo& s)
{
  int64_t samples = 1;
  for (int a = 0; a < 3; ++a)
  {
    // Each factor is checked before it multiplies: the product stays below 2^34 * 2^20, far from overflow.
    if (s.dims[a] < 1 || s.dims[a] > kMaxSourceAxisSamples)
      NV_THROW("source dimension " + std::to_string(a) + " is " + std::to_string(s.dims[a]) +
        " samples; a model states 1 to " + std::to_string(kMaxSourceAxisSamples) + " per axis");
    samples *= s.dims[a];
    if (samples > kMaxSourceSamples)
      NV_THROW("source grid of " + std::to_string(s.dims[0]) + " x " + std::to_string(s.dims[1]) + " x " +
        std::to_string(s.dims[2]) + " samples; a model states at most " + std::to_string(kMaxSourceSamples) +
        " (2^34) samples");
  }
  for (int a = 0; a < 3; ++a)
  {
    const std::string axis = std::to_string(a);
    if (!std::isfinite(s.origin[a]))
      NV_THROW("source origin " + axis + " is not finite");
    // An axis of one sample (a flat image) may state any finite non-negative spacing, 0 included.
    if (!(std::isfinite(s.spacing[a]) && (s.spacing[a] > 0.0 || (s.spacing[a] == 0.0 && s.dims[a] == 1))))
      NV_THROW("source spacing " + axis + " is " + std::to_string(s.spacing[a]) + "; it must be positive and finite");
    const double lo = s.bounds[2 * a], hi = s.bounds[2 * a + 1];
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo <= hi))
      NV_THROW("source bounds " + std::to_string(lo) + " .. " + std::to_string(hi) + " on axis " + axis +
        ": they must be finite with min <= max");
  }
  if (!(std::isfinite(s.valueMin) && std::isfinite(s.valueMax) && s.valueMax >= s.valueMin))
    NV_THROW("source value range " + std::to_string(s.valueMin) + " .. " + std::to_string(s.valueMax) +
      ": it must be finite with min <= max");
  if (s.association != 0 && s.association != 1)
    NV_THROW("source association " + std::to_string(s.association) + " (0 = points, 1 = cells)");
  if (s.rawBytes < 0)
    NV_THROW("negative source size " + std::to_string(s.rawBytes));
  if (!s.domain.empty())
  {
    if (samples > kMaxDomainSamples)
      NV_THROW("a domain mask over " + std::to_string(samples) + " samples (at most 2^32 - 1)");
    if (int64_t(s.domain.size()) != domainWords(s.dims))
      NV_THROW("domain mask size does not match the source dims");
  }
  if (!s.occupancy.empty())
  {
    if (!std::isfinite(s.background))
      NV_THROW("a background that is not finite");
    if (int64_t(s.occupancy.size()) != occupancyWords(s.dims))
      NV_THROW("occupancy mask size does not match the macrocells");
  }
}

bool inDomain(const SourceInfo& src, const float u[3])
{
  const int64_t samples = src.dims[0] * src.dims[1] * src.dims[2];
  if (src.domain.empty() || int64_t(src.domain.size()) != (samples + 31) / 32)
    return true;
  const int dims[3] = { static_cast<int>(src.dims[0]), static_cast<int>(src.dims[1]), static_cast<int>(src.dims[2]) };
  return domainBit(src.domain.data(), dims, u[0], u[1], u[2]);
}
} // namespace nv
