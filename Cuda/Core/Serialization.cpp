#include "Serialization.h"

#include "Error.h"
#include "Macrocells.h"

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
  Reader(const uint8_t* d, size_t n)
    : Data(d)
    , Size(n)
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
    NV_CHECK(n <= 4096, std::string("corrupt model: ") + what + " is " + std::to_string(n) + " bytes long");
    need(n, what);
    std::string s(reinterpret_cast<const char*>(Data + Pos), n);
    Pos += n;
    return s;
  }
  void need(size_t n, const char* what)
  {
    if (Size - Pos < n)
    {
      NV_THROW(std::string("truncated model data: ") + std::to_string(Size) + " bytes end inside '" + what + "'");
    }
  }
  const uint8_t* here() const { return Data + Pos; }
  void skip(size_t n) { Pos += n; }
  size_t pos() const { return Pos; }

private:
  const uint8_t* Data;
  size_t Size;
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
/// Slicing-by-8 tables of the reflected CRC-32 polynomial (built once, thread-safe).
struct CrcTables
{
  uint32_t t[8][256];
  CrcTables()
  {
    for (uint32_t i = 0; i < 256; ++i)
    {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k)
        c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; ++i)
      for (int s = 1; s < 8; ++s)
        t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFu];
  }
};

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

uint32_t crc32(const uint8_t* data, size_t size)
{
  static const CrcTables tables;
  const auto& t = tables.t;
  uint32_t c = 0xFFFFFFFFu;
  size_t i = 0;
  for (; i + 8 <= size; i += 8)
  {
    uint32_t lo, hi;
    std::memcpy(&lo, data + i, 4); // little endian (checked by the format)
    std::memcpy(&hi, data + i + 4, 4);
    lo ^= c;
    c = t[7][lo & 0xFFu] ^ t[6][(lo >> 8) & 0xFFu] ^ t[5][(lo >> 16) & 0xFFu] ^ t[4][lo >> 24] ^
      t[3][hi & 0xFFu] ^ t[2][(hi >> 8) & 0xFFu] ^ t[1][(hi >> 16) & 0xFFu] ^ t[0][hi >> 24];
  }
  for (; i < size; ++i)
    c = t[0][(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::vector<uint8_t> serialize(const Model& model)
{
  checkLittleEndian();
  Writer h; // header fields
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

  const bool mask = !s.domain.empty(), occupancy = !s.occupancy.empty();
  Writer w;
  w.bytes.insert(w.bytes.end(), kMagic, kMagic + 8);
  w.put<uint32_t>(occupancy ? kFormatVersion : mask ? kFormatVersionDomain : kFormatVersionNoMask);
  w.put<uint32_t>(static_cast<uint32_t>(h.bytes.size()));
  w.bytes.insert(w.bytes.end(), h.bytes.begin(), h.bytes.end());
  const std::vector<float>& p = model.params();
  w.put<uint64_t>(p.size());
  if (model.storagePrecision() == Precision::Float16)
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
  // A bit mask of `count` bits as alternating run lengths, starting with 0-bits.
  auto putRuns = [&w](const std::vector<uint32_t>& bits, int64_t count) {
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
  };
  if (occupancy)
    w.put<uint32_t>((mask ? 1u : 0u) | 2u);
  if (mask)
  {
    const int64_t samples = s.dims[0] * s.dims[1] * s.dims[2];
    NV_CHECK(int64_t(s.domain.size()) == (samples + 31) / 32, "domain mask size does not match the source dims");
    putRuns(s.domain, samples);
  }
  if (occupancy)
  {
    const MacrocellLayout cells = macrocellLayout(s.dims);
    const int64_t count = int64_t(cells.dims[0]) * cells.dims[1] * cells.dims[2];
    NV_CHECK(int64_t(s.occupancy.size()) == (count + 31) / 32, "occupancy mask size does not match the macrocells");
    putRuns(s.occupancy, count);
    w.put<double>(s.background);
  }
  w.put<uint32_t>(crc32(w.bytes.data(), w.bytes.size()));
  return std::move(w.bytes);
}

Model deserialize(const uint8_t* data, size_t size)
{
  checkLittleEndian();
  NV_CHECK(data != nullptr || size == 0, "null model data");
  if (size < 8 || std::memcmp(data, kMagic, 8) != 0)
  {
    NV_THROW("not a NeuralVolume model (bad magic; " + std::to_string(size) + " bytes)");
  }
  Reader r(data, size);
  r.skip(8);
  const uint32_t version = r.get<uint32_t>("version");
  if (version != kFormatVersion && version != kFormatVersionDomain && version != kFormatVersionNoMask)
  {
    NV_THROW("unsupported NeuralVolume model version " + std::to_string(version) + " (this build reads version " +
      std::to_string(kFormatVersion) + ")");
  }
  const uint32_t headerBytes = r.get<uint32_t>("header size");
  r.need(headerBytes, "header");
  if (size >= 4)
  {
    uint32_t stored;
    std::memcpy(&stored, data + size - 4, 4);
    if (size < 4 + r.pos() + headerBytes + 8 || crc32(data, size - 4) != stored)
    {
      // Decide between truncation and corruption for a clearer message.
      NV_THROW("corrupt or truncated NeuralVolume model: checksum mismatch over " + std::to_string(size) + " bytes");
    }
  }
  const size_t headerStart = r.pos();
  ModelConfig c;
  c.encoding.levels = r.get<int32_t>("levels");
  c.encoding.featuresPerLevel = r.get<int32_t>("features");
  c.encoding.log2TableSize = r.get<int32_t>("log2 table size");
  c.encoding.baseResolution = r.get<int32_t>("base resolution");
  c.encoding.perLevelScale = r.get<double>("per-level scale");
  c.encoding.finestResolution = r.get<int32_t>("finest resolution");
  c.network.width = r.get<int32_t>("width");
  c.network.hiddenLayers = r.get<int32_t>("hidden layers");
  const int32_t precision = r.get<int32_t>("precision");
  NV_CHECK(precision == 0 || precision == 1, "corrupt model: unknown parameter precision " + std::to_string(precision));
  Model m(c); // validates the configuration
  SourceInfo& s = m.source;
  for (int i = 0; i < 3; ++i)
    s.dims[i] = r.get<int64_t>("dims");
  for (int i = 0; i < 3; ++i)
    s.origin[i] = r.get<double>("origin");
  for (int i = 0; i < 3; ++i)
    s.spacing[i] = r.get<double>("spacing");
  for (int i = 0; i < 6; ++i)
    s.bounds[i] = r.get<double>("bounds");
  s.valueMin = r.get<double>("value min");
  s.valueMax = r.get<double>("value max");
  s.association = r.get<int32_t>("association");
  s.rawBytes = r.get<int64_t>("raw bytes");
  s.arrayName = r.getString("array name");
  TrainingStats& t = m.stats;
  t.steps = r.get<int64_t>("steps");
  t.seconds = r.get<double>("seconds");
  t.finalLoss = r.get<double>("final loss");
  t.psnr = r.get<double>("psnr");
  t.maxError = r.get<double>("max error");
  t.invalidSamples = r.get<int64_t>("invalid samples");
  t.device = r.getString("device");
  NV_CHECK(r.pos() - headerStart == headerBytes, "corrupt model: header size mismatch");
  for (int i = 0; i < 3; ++i)
    NV_CHECK(s.dims[i] >= 1, "corrupt model: non-positive source dimension");
  NV_CHECK(std::isfinite(s.valueMin) && std::isfinite(s.valueMax) && s.valueMax >= s.valueMin,
    "corrupt model: invalid value range");

  const uint64_t n = r.get<uint64_t>("parameter count");
  NV_CHECK(n == m.paramCount(), "corrupt model: " + std::to_string(n) + " parameters stored, configuration needs " +
      std::to_string(m.paramCount()));
  std::vector<float>& p = m.params();
  if (precision == 1)
  {
    r.need(n * 2, "parameters");
    const float* table = halfTable();
    const uint8_t* src = r.here();
    for (uint64_t i = 0; i < n; ++i)
    {
      uint16_t h;
      std::memcpy(&h, src + 2 * i, 2);
      p[i] = table[h];
    }
    r.skip(n * 2);
    m.setStoragePrecision(Precision::Float16); // the values are fp16 already
  }
  else
  {
    r.need(n * 4, "parameters");
    std::memcpy(p.data(), r.here(), n * 4);
    r.skip(n * 4);
  }
  // Version 2: a domain mask; version 3: flags saying which masks follow.
  const uint32_t flags = version >= 3 ? r.get<uint32_t>("mask flags") : version == 2 ? 1u : 0u;
  NV_CHECK(flags <= 3u && (version < 3 || (flags & 2u)), "corrupt model: mask flags " + std::to_string(flags));
  auto getRuns = [&r](std::vector<uint32_t>& bits, int64_t samples, const char* what) {
    const uint64_t count = r.get<uint64_t>(what);
    NV_CHECK(count >= 1 && count <= uint64_t(samples) + 1,
      std::string("corrupt model: ") + std::to_string(count) + " runs of the " + what);
    r.need(count * 4, what);
    bits.assign(size_t((samples + 31) / 32), 0u);
    int64_t at = 0;
    for (uint64_t k = 0; k < count; ++k)
    {
      const int64_t len = r.get<uint32_t>(what);
      NV_CHECK(len <= samples - at, std::string("corrupt model: the runs of the ") + what + " exceed its samples");
      if (k % 2 == 1)
        for (int64_t i = at; i < at + len; ++i)
          bits[size_t(i >> 5)] |= 1u << (i & 31);
      at += len;
    }
    NV_CHECK(at == samples, std::string("corrupt model: the runs of the ") + what + " cover " + std::to_string(at) +
        " of " + std::to_string(samples) + " samples");
  };
  if (flags & 1u)
  {
    const int64_t samples = s.dims[0] * s.dims[1] * s.dims[2];
    NV_CHECK(s.dims[0] <= (1 << 20) && s.dims[1] <= (1 << 20) && s.dims[2] <= (1 << 20) && samples < (int64_t(1) << 32),
      "corrupt model: a domain mask over " + std::to_string(samples) + " samples");
    getRuns(s.domain, samples, "domain mask");
  }
  if (flags & 2u)
  {
    NV_CHECK(s.dims[0] <= (1 << 20) && s.dims[1] <= (1 << 20) && s.dims[2] <= (1 << 20),
      "corrupt model: an occupancy mask over " + std::to_string(s.dims[0]) + " x " + std::to_string(s.dims[1]) + " x " +
        std::to_string(s.dims[2]) + " samples");
    const MacrocellLayout cells = macrocellLayout(s.dims);
    getRuns(s.occupancy, int64_t(cells.dims[0]) * cells.dims[1] * cells.dims[2], "occupancy mask");
    s.background = r.get<double>("background");
    NV_CHECK(std::isfinite(s.background), "corrupt model: a background that is not finite");
  }
  NV_CHECK(r.pos() + 4 == size, "corrupt model: " + std::to_string(size - r.pos() - 4) + " unexpected trailing bytes");
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
