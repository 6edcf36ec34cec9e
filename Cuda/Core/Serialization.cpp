#include "Serialization.h"

#include "Error.h"
#include "Macrocells.h"
#include "QuantizedParameters.h"
#include "ResourceEstimate.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

namespace nv
{
namespace
{
const char kMagic[8] = { 'N', 'V', 'O', 'L', 'N', 'E', 'T', '\0' };

class Writer
{
public:
  std::vector<uint8_t> bytes;
  template <typename T>
  void put(T v)
  {
    const uint8_t* p = reinterpret_cast<const uint8_t*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  void putString(const std::string& s)
  {
    put<uint32_t>(static_cast<uint32_t>(s.size()));
    bytes.insert(bytes.end(), s.begin(), s.end());
  }
};

class Reader
{
public:
  /// `label` names the bytes in messages: "model data", or "model header" for a header's own bytes.
  Reader(const uint8_t* d, size_t n, const char* label = "model data")
    : Data(d)
    , Size(n)
    , Label(label)
  {
  }
  template <typename T>
  T get(const char* what)
  {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, Data + Pos, sizeof(T));
    Pos += sizeof(T);
    return v;
  }
  std::string getString(const char* what)
  {
    const uint32_t n = get<uint32_t>(what);
    if (n > 4096)
      throw Error(std::string("corrupt NeuralVolume model: ") + what + " is " + std::to_string(n) + " bytes long");
    need(n, what);
    std::string s(reinterpret_cast<const char*>(Data + Pos), n);
    Pos += n;
    return s;
  }
  void need(size_t n, const char* what)
  {
    if (Size - Pos < n)
    {
      NV_THROW(std::string("truncated ") + Label + ": " + std::to_string(Size) + " bytes end inside '" + what + "'");
    }
  }
  const uint8_t* here() const { return Data + Pos; }
  void skip(size_t n) { Pos += n; }
  size_t pos() const { return Pos; }

private:
  const uint8_t* Data;
  size_t Size;
  const char* Label;
  size_t Pos = 0;
};

void checkLittleEndian()
{
  const uint16_t one = 1;
  uint8_t b;
  std::memcpy(&b, &one, 1);
  NV_CHECK(b == 1, "the model format is little endian; big-endian hosts are not supported");
}
} // namespace

namespace
{
/// fp16 -> fp32 for every 16-bit pattern (built once, thread-safe): decoding a stored network is a table lookup.
const float* halfTable()
{
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    for (uint32_t h = 0; h < 65536; ++h)
      t[h] = halfToFloat(static_cast<uint16_t>(h));
    return t;
  }();
  return table.data();
}
} // namespace


namespace
{
// serialize()'s steps, in the order of the bytes they write.

/// The header's fields: the configuration, the source's geometry and values, the training statistics.
Writer headerFields(const Model& model)
{
  Writer h;
  const ModelConfig& c = model.config();
  h.put<int32_t>(c.encoding.levels);
  h.put<int32_t>(c.encoding.featuresPerLevel);
  h.put<int32_t>(c.encoding.log2TableSize);
  h.put<int32_t>(c.encoding.baseResolution);
  h.put<double>(c.encoding.perLevelScale);
  h.put<int32_t>(c.encoding.finestResolution);
  h.put<int32_t>(c.network.width);
  h.put<int32_t>(c.network.hiddenLayers);
  h.put<int32_t>(static_cast<int32_t>(model.storagePrecision()));
  const SourceInfo& s = model.source;
  for (int i = 0; i < 3; ++i)
    h.put<int64_t>(s.dims[i]);
  for (int i = 0; i < 3; ++i)
    h.put<double>(s.origin[i]);
  for (int i = 0; i < 3; ++i)
    h.put<double>(s.spacing[i]);
  for (int i = 0; i < 6; ++i)
    h.put<double>(s.bounds[i]);
  h.put<double>(s.valueMin);
  h.put<double>(s.valueMax);
  h.put<int32_t>(s.association);
  h.put<int64_t>(s.rawBytes);
  h.putString(s.arrayName);
  const TrainingStats& t = model.stats;
  h.put<int64_t>(t.steps);
  h.put<double>(t.seconds);
  h.put<double>(t.finalLoss);
  h.put<double>(t.psnr);
  h.put<double>(t.maxError);
  h.put<int64_t>(t.invalidSamples);
  h.putString(t.device);
  return h;
}

/// The parameters in the model's storage precision (Quantized8: the coded block, with its size first).
void putParameters(Writer& w, const Model& model, bool quantized)
{
  const std::vector<float>& p = model.params();
  w.put<uint64_t>(p.size());
  if (quantized)
  {
    std::vector<uint8_t> coded;
    const std::vector<uint8_t>* block = model.codedParameters(); // quantize()'s, unless the parameters changed since
    if (!block)
    {
      coded = encodeQuantizedParameters(model);
      block = &coded;
    }
    w.put<uint64_t>(block->size());
    w.bytes.insert(w.bytes.end(), block->begin(), block->end());
  }
  else if (model.storagePrecision() == Precision::Float16)
  {
    const size_t at = w.bytes.size();
    w.bytes.resize(at + p.size() * sizeof(uint16_t));
    for (size_t i = 0; i < p.size(); ++i)
    {
      const uint16_t h = floatToHalf(p[i]);
      std::memcpy(w.bytes.data() + at + 2 * i, &h, 2);
    }
  }
  else
  {
    const uint8_t* b = reinterpret_cast<const uint8_t*>(p.data());
    w.bytes.insert(w.bytes.end(), b, b + p.size() * sizeof(float));
  }
}

/// A bit mask of `count` bits as alternating run lengths, starting with 0-bits.
void putRuns(Writer& w, const std::vector<uint32_t>& bits, int64_t count)
{
  std::vector<uint32_t> runs;
  uint32_t value = 0, length = 0;
  for (int64_t i = 0; i < count; ++i)
  {
    const uint32_t bit = (bits[size_t(i >> 5)] >> (i & 31)) & 1u;
    if (bit != value)
    {
      runs.push_back(length);
      value = bit;
      length = 0;
    }
    ++length;
  }
  runs.push_back(length);
  w.put<uint64_t>(runs.size());
  for (uint32_t r : runs)
    w.put<uint32_t>(r);
}

/// The mask flags (versions 3 and 4), the domain mask, the occupancy mask and the background.
void putMasks(Writer& w, const SourceInfo& s, bool quantized)
{
  const bool mask = !s.domain.empty(), occupancy = !s.occupancy.empty();
  if (occupancy || quantized)
    w.put<uint32_t>((mask ? 1u : 0u) | (occupancy ? 2u : 0u));
  if (mask)
  {
    const int64_t samples = s.dims[0] * s.dims[1] * s.dims[2];
    NV_CHECK(int64_t(s.domain.size()) == (samples + 31) / 32, "domain mask size does not match the source dims");
    putRuns(w, s.domain, samples);
  }
  if (occupancy)
  {
    const MacrocellLayout cells = macrocellLayout(s.dims);
    const int64_t count = int64_t(cells.dims[0]) * cells.dims[1] * cells.dims[2];
    NV_CHECK(int64_t(s.occupancy.size()) == (count + 31) / 32, "occupancy mask size does not match the macrocells");
    putRuns(w, s.occupancy, count);
    w.put<double>(s.background);
  }
}
} // namespace

std::vector<uint8_t> serialize(const Model& model)
{
  checkLittleEndian();
  validate(model.source); // the reader refuses what this refuses: every written model reads back
  NV_CHECK(model.source.arrayName.size() <= 4096 && model.stats.device.size() <= 4096,
    "array and device names of a model are at most 4096 bytes");
  const Writer h = headerFields(model);

  const SourceInfo& s = model.source;
  const bool mask = !s.domain.empty(), occupancy = !s.occupancy.empty();
  const bool quantized = model.storagePrecision() == Precision::Quantized8;
  const ErrorCorrections& c = model.corrections;
  validateErrorBound(c.bound);
  Writer w;
  w.bytes.insert(w.bytes.end(), kMagic, kMagic + 8);
  w.put<uint32_t>(c.enabled() ? kFormatVersionCorrections
      : quantized           ? kFormatVersionQuantized
      : occupancy           ? kFormatVersionOccupancy
      : mask                ? kFormatVersionDomain
                            : kFormatVersionNoMask);
  w.put<uint32_t>(static_cast<uint32_t>(h.bytes.size()));
  w.bytes.insert(w.bytes.end(), h.bytes.begin(), h.bytes.end());
  putParameters(w, model, quantized);
  putMasks(w, s, quantized || c.enabled());
  if (c.enabled())
  {
    NV_CHECK(c.index.empty() || (c.index.front() >= 0 && c.index.back() < s.dims[0] * s.dims[1] * s.dims[2]),
      "error corrections outside the source grid");
    const std::vector<uint8_t> list = encodeCorrections(c);
    w.put<double>(c.bound);
    w.put<uint64_t>(c.index.size());
    w.put<uint64_t>(list.size());
    w.bytes.insert(w.bytes.end(), list.begin(), list.end());
  }
  w.put<uint32_t>(crc32(w.bytes.data(), w.bytes.size()));
  return std::move(w.bytes);
}

namespace
{
[[noreturn]] void corrupt(const std::string& what)
{
  throw Error("corrupt NeuralVolume model: " + what);
}

/// Runs `check` (a validate() of Model.h or Config.h); its error becomes a corrupt-model error about `part` (when
/// not null).
template <typename F>
void checkField(const char* part, F&& check)
{
  try
  {
    check();
  }
  catch (const Error& e)
  {
    corrupt(part ? std::string(part) + ": " + e.what() : std::string(e.what()));
  }
}

/// Checks a run-length mask of `samples` bits at the reader's position without allocating: its count against the
/// bytes present, every run against the bits left. Leaves the reader after the runs; returns their count.
uint64_t scanRuns(Reader& r, int64_t samples, const char* what)
{
  const uint64_t count = r.get<uint64_t>(what);
  if (count < 1 || count > uint64_t(samples) + 1)
    corrupt(std::to_string(count) + " runs in the " + what + " of " + std::to_string(samples) + " bits");
  r.need(size_t(count) * 4, what); // count <= 2^34 + 1: no overflow
  const uint8_t* p = r.here();
  int64_t at = 0;
  for (uint64_t k = 0; k < count; ++k)
  {
    uint32_t len;
    std::memcpy(&len, p + 4 * k, 4);
    if (int64_t(len) > samples - at)
      corrupt(std::string("the runs of the ") + what + " exceed its " + std::to_string(samples) + " bits");
    at += len;
  }
  if (at != samples)
    corrupt(std::string("the runs of the ") + what + " cover " + std::to_string(at) + " of " +
      std::to_string(samples) + " bits");
  r.skip(size_t(count) * 4);
  return count;
}

/// The bits of a mask whose runs scanRuns() accepted: odd runs are 1-bits.
std::vector<uint32_t> fillRuns(const uint8_t* runs, uint64_t count, int64_t samples)
{
  std::vector<uint32_t> bits(size_t((samples + 31) / 32), 0u);
  int64_t at = 0;
  for (uint64_t k = 0; k < count; ++k)
  {
    uint32_t len;
    std::memcpy(&len, runs + 4 * k, 4);
    int64_t i = at;
    const int64_t end = at + len;
    if (k % 2 == 1)
    {
      for (; i < end && (i & 31) != 0; ++i)
        bits[size_t(i >> 5)] |= 1u << (i & 31);
      for (; i + 32 <= end; i += 32)
        bits[size_t(i >> 5)] = 0xFFFFFFFFu;
      for (; i < end; ++i)
        bits[size_t(i >> 5)] |= 1u << (i & 31);
    }
    at = end;
  }
  return bits;
}
} // namespace

namespace
{
// inspectModel()'s steps, in the order of the bytes they read: every check where it always was.

/// The magic, the version, the header's size (the header, parameter count and checksum must fit) and the checksum
/// over the whole file. Leaves `r` at the header; returns its size.
uint32_t readPreamble(Reader& r, const uint8_t* data, size_t size, ModelFileInfo& info)
{
  checkLittleEndian();
  NV_CHECK(data != nullptr || size == 0, "null model data");
  if (size < 8 || std::memcmp(data, kMagic, 8) != 0)
  {
    NV_THROW("not a NeuralVolume model (bad magic; " + std::to_string(size) + " bytes)");
  }
  r.skip(8);
  info.version = r.get<uint32_t>("version");
  if (info.version < kFormatVersionNoMask || info.version > kFormatVersion)
  {
    NV_THROW("unsupported NeuralVolume model version " + std::to_string(info.version) + " (this build reads versions 1 to " +
      std::to_string(kFormatVersion) + ")");
  }
  const uint32_t headerBytes = r.get<uint32_t>("header size");
  if (headerBytes > kMaxHeaderBytes)
    corrupt("a header of " + std::to_string(headerBytes) + " bytes (at most " + std::to_string(kMaxHeaderBytes) + ")");
  r.need(size_t(headerBytes) + 8 + 4, "header"); // and the parameter count and checksum after it
  uint32_t stored;
  std::memcpy(&stored, data + size - 4, 4);
  if (crc32(data, size - 4) != stored)
  {
    NV_THROW("corrupt or truncated NeuralVolume model: checksum mismatch over " + std::to_string(size) + " bytes");
  }
  return headerBytes;
}

/// The header's fields, read within its own `headerBytes` bytes (all of them). Returns the parameter count the
/// configuration needs.
uint64_t readHeader(Reader& h, uint32_t headerBytes, ModelFileInfo& info)
{
  ModelConfig& c = info.config;
  c.encoding.levels = h.get<int32_t>("levels");
  c.encoding.featuresPerLevel = h.get<int32_t>("features");
  c.encoding.log2TableSize = h.get<int32_t>("log2 table size");
  c.encoding.baseResolution = h.get<int32_t>("base resolution");
  c.encoding.perLevelScale = h.get<double>("per-level scale");
  c.encoding.finestResolution = h.get<int32_t>("finest resolution");
  c.network.width = h.get<int32_t>("width");
  c.network.hiddenLayers = h.get<int32_t>("hidden layers");
  const int32_t precision = h.get<int32_t>("precision");
  if (precision != 0 && precision != 1 && precision != 2)
    corrupt("unknown parameter precision " + std::to_string(precision));
  if (info.version != kFormatVersionCorrections && (precision == 2) != (info.version == kFormatVersionQuantized))
    corrupt("parameter precision " + std::to_string(precision) + " in version " + std::to_string(info.version) +
      " (8-bit quantised parameters are version 4, and version 4 holds only those)");
  info.precision = static_cast<Precision>(precision);
  uint64_t expected = 0;
  checkField("configuration", [&] { expected = uint64_t(parameterCount(c)); }); // <= 2^31 + 2^17
  SourceInfo& s = info.source;
  for (int i = 0; i < 3; ++i)
    s.dims[i] = h.get<int64_t>("dims");
  for (int i = 0; i < 3; ++i)
    s.origin[i] = h.get<double>("origin");
  for (int i = 0; i < 3; ++i)
    s.spacing[i] = h.get<double>("spacing");
  for (int i = 0; i < 6; ++i)
    s.bounds[i] = h.get<double>("bounds");
  s.valueMin = h.get<double>("value min");
  s.valueMax = h.get<double>("value max");
  s.association = h.get<int32_t>("association");
  s.rawBytes = h.get<int64_t>("raw bytes");
  checkField(nullptr, [&] { validate(s); }); // before the strings: dims, geometry, ranges
  s.arrayName = h.getString("array name");
  TrainingStats& t = info.stats;
  t.steps = h.get<int64_t>("steps");
  t.seconds = h.get<double>("seconds");
  t.finalLoss = h.get<double>("final loss");
  t.psnr = h.get<double>("psnr");
  t.maxError = h.get<double>("max error");
  t.invalidSamples = h.get<int64_t>("invalid samples");
  t.device = h.getString("device");
  if (h.pos() != headerBytes)
    corrupt("header size mismatch (" + std::to_string(headerBytes) + " bytes stated, " + std::to_string(h.pos()) +
      " read)");
  if (t.steps < 0 || t.invalidSamples < 0)
    corrupt("negative training counts");
  return expected;
}

/// The parameter count (it must be `expected`) and the stored parameters, checked and skipped.
void readParameters(Reader& r, size_t size, uint64_t expected, ModelFileInfo& info)
{
  const ModelConfig& c = info.config;
  info.parameterCount = r.get<uint64_t>("parameter count");
  if (info.parameterCount != expected)
    corrupt(std::to_string(info.parameterCount) + " parameters stored, the configuration needs " +
      std::to_string(expected));
  if (info.precision == Precision::Quantized8)
  {
    const uint64_t blockBytes = r.get<uint64_t>("quantised parameter bytes");
    if (blockBytes > size)
      corrupt("a quantised parameter block of " + std::to_string(blockBytes) + " bytes in a file of " +
        std::to_string(size));
    r.need(size_t(blockBytes), "quantised parameters");
    info.parametersAt = r.pos();
    info.parameterBytes = size_t(blockBytes);
    size_t used = 0;
    checkField(nullptr, [&] { used = inspectQuantizedParameters(r.here(), size_t(blockBytes), c); });
    if (used != blockBytes)
      corrupt("the quantised parameters take " + std::to_string(used) + " of the " + std::to_string(blockBytes) +
        " bytes stated");
    r.skip(size_t(blockBytes));
  }
  else
  {
    const size_t bytesPer = info.precision == Precision::Float16 ? 2 : 4;
    r.need(size_t(expected) * bytesPer, "parameters"); // expected <= 2^31 + 2^17: no overflow
    info.parametersAt = r.pos();
    info.parameterBytes = size_t(expected) * bytesPer;
    r.skip(size_t(expected) * bytesPer);
  }
  info.hostBytes = expected * 4;
}

/// The mask flags (versions 3 and 4), the domain mask's and the occupancy mask's runs (checked, not filled) and the
/// background.
void readMasks(Reader& r, ModelFileInfo& info)
{
  SourceInfo& s = info.source;
  // Version 2: a domain mask; versions 3 and 4: flags saying which masks follow (version 3: an occupancy mask always).
  const uint32_t flags = info.version >= 3 ? r.get<uint32_t>("mask flags") : info.version == 2 ? 1u : 0u;
  if (flags > 3u || (info.version == 3 && !(flags & 2u)))
    corrupt("mask flags " + std::to_string(flags) + " in version " + std::to_string(info.version));
  info.hasDomain = (flags & 1u) != 0;
  info.hasOccupancy = (flags & 2u) != 0;
  if (info.hasDomain)
  {
    const int64_t samples = s.dims[0] * s.dims[1] * s.dims[2]; // <= 2^34 (validated)
    if (samples > kMaxDomainSamples)
      corrupt("a domain mask over " + std::to_string(samples) + " samples (at most 2^32 - 1)");
    info.domainRunsAt = r.pos() + 8;
    info.domainRuns = scanRuns(r, samples, "domain mask");
    info.hostBytes += uint64_t(domainWords(s.dims)) * 4;
  }
  if (info.hasOccupancy)
  {
    const MacrocellLayout cells = macrocellLayout(s.dims);
    info.occupancyRunsAt = r.pos() + 8;
    info.occupancyRuns = scanRuns(r, int64_t(cells.dims[0]) * cells.dims[1] * cells.dims[2], "occupancy mask");
    s.background = r.get<double>("background");
    if (!std::isfinite(s.background))
      corrupt("a background that is not finite");
    info.hostBytes += uint64_t(occupancyWords(s.dims)) * 4;
  }
}

/// Version 5: the error bound, the correction count and the coded list (checked, not decoded).
void readCorrections(Reader& r, ModelFileInfo& info)
{
  info.correctionBound = r.get<double>("error bound");
  if (!(std::isfinite(info.correctionBound) && info.correctionBound > 0.0))
    corrupt("an error bound of " + std::to_string(info.correctionBound) + " (it must be finite and > 0)");
  info.correctionCount = r.get<uint64_t>("correction count");
  const uint64_t bytes = r.get<uint64_t>("correction bytes");
  const int64_t samples = info.source.dims[0] * info.source.dims[1] * info.source.dims[2];
  if (bytes > uint64_t(1) << 40)
    corrupt("a correction list of " + std::to_string(bytes) + " bytes");
  r.need(size_t(bytes), "error corrections");
  checkField(nullptr, [&] { inspectCorrections(r.here(), size_t(bytes), info.correctionCount, samples); });
  info.correctionsAt = r.pos();
  info.correctionBytes = size_t(bytes);
  info.hostBytes += info.correctionCount * 12; // an index and a step each
  r.skip(size_t(bytes));
}
} // namespace

ModelFileInfo inspectModel(const uint8_t* data, size_t size)
{
  ModelFileInfo info;
  Reader r(data, size);
  const uint32_t headerBytes = readPreamble(r, data, size, info);
  // The header, read within its own bytes.
  Reader h(r.here(), headerBytes, "model header");
  r.skip(headerBytes);
  const uint64_t expected = readHeader(h, headerBytes, info);
  readParameters(r, size, expected, info);
  readMasks(r, info);
  if (info.version == kFormatVersionCorrections)
    readCorrections(r, info);
  if (r.pos() + 4 != size)
    corrupt(std::to_string(size - r.pos() - 4) + " unexpected trailing bytes");
  return info;
}

Model deserialize(const uint8_t* data, size_t size)
{
  const ModelFileInfo info = inspectModel(data, size); // every check; nothing large allocated yet
  Model m(info.config);
  NV_CHECK(m.paramCount() == info.parameterCount, "parameter count of the configuration");
  m.source = info.source;
  m.stats = info.stats;
  std::vector<float>& p = m.params();
  const uint8_t* src = data + info.parametersAt;
  if (info.precision == Precision::Quantized8)
  {
    try
    {
      decodeQuantizedParameters(src, info.parameterBytes, m);
    }
    catch (const Error& e)
    {
      corrupt(e.what());
    }
  }
  else if (info.precision == Precision::Float16)
  {
    const float* table = halfTable();
    for (size_t i = 0; i < p.size(); ++i)
    {
      uint16_t h;
      std::memcpy(&h, src + 2 * i, 2);
      p[i] = table[h];
    }
    m.setStoragePrecision(Precision::Float16); // the values are fp16 already
  }
  else if (!p.empty())
  {
    std::memcpy(p.data(), src, p.size() * 4);
  }
  SourceInfo& s = m.source;
  if (info.hasDomain)
    s.domain = fillRuns(data + info.domainRunsAt, info.domainRuns, s.dims[0] * s.dims[1] * s.dims[2]);
  if (info.hasOccupancy)
  {
    const MacrocellLayout cells = macrocellLayout(s.dims);
    s.occupancy = fillRuns(
      data + info.occupancyRunsAt, info.occupancyRuns, int64_t(cells.dims[0]) * cells.dims[1] * cells.dims[2]);
  }
  if (info.version == kFormatVersionCorrections)
    m.corrections = decodeCorrections(data + info.correctionsAt, info.correctionBytes, info.correctionCount,
      s.dims[0] * s.dims[1] * s.dims[2], info.correctionBound);
  return m;
}

void saveModel(const Model& model, const std::string& path)
{
  const std::vector<uint8_t> b = serialize(model);
  std::ofstream f(path, std::ios::binary);
  NV_CHECK(f.good(), "cannot open '" + path + "' for writing");
  f.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  NV_CHECK(f.good(), "failed writing '" + path + "'");
}

Model loadModel(const std::string& path)
{
  std::ifstream f(path, std::ios::binary);
  NV_CHECK(f.good(), "cannot open model file '" + path + "'");
  std::vector<uint8_t> b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return deserialize(b);
}

} // namespace nv
