#include "QuantizedParameters.h"

#include "Error.h"
#include "GridQuantizer.h"
#include "RansCoder.h"

#include <cstring>
#include <string>

namespace nv
{
namespace
{
[[noreturn]] void corrupt(const std::string& what)
{
  throw Error("quantised parameters: " + what);
}

/// Reads a level's step at data[pos] (4 bytes checked by the caller's bounds) and validates it.
float readStep(const uint8_t* data, size_t size, size_t pos, int level)
{
  if (size - pos < 4)
    corrupt("the block ends before the step of level " + std::to_string(level));
  float step;
  std::memcpy(&step, data + pos, 4);
  if (!GridQuantizer::validStep(step))
    corrupt("level " + std::to_string(level) + " has step " + std::to_string(step) +
      " (0, or a normal positive float whose 127 multiple is finite)");
  return step;
}
} // namespace

std::vector<uint8_t> encodeQuantizedParameters(const Model& model)
{
  const GridLayout& g = model.layout();
  const std::vector<float>& steps = model.levelSteps();
  NV_CHECK(int(steps.size()) == g.levels, "a Quantized8 model needs one step per level (call quantize())");
  const std::vector<float>& p = model.params();
  std::vector<uint8_t> out;
  std::vector<uint8_t> symbols;
  for (int l = 0; l < g.levels; ++l)
  {
    const float step = steps[size_t(l)];
    NV_CHECK(GridQuantizer::validStep(step), "invalid quantisation step of level " + std::to_string(l));
    const uint8_t* s = reinterpret_cast<const uint8_t*>(&step);
    out.insert(out.end(), s, s + 4);
    const size_t begin = size_t(g.level[l].offset) * g.features;
    const size_t n = size_t(g.level[l].entries) * g.features;
    symbols.resize(n);
    for (size_t i = 0; i < n; ++i)
      symbols[i] = GridQuantizer::symbol(GridQuantizer::code(p[begin + i], step));
    RansCoder::encode(symbols.data(), n, out);
  }
  const size_t mlpAt = model.encodingParamCount();
  const size_t at = out.size();
  out.resize(at + 2 * model.mlpParamCount());
  for (size_t i = 0; i < model.mlpParamCount(); ++i)
  {
    const uint16_t h = floatToHalf(p[mlpAt + i]);
    std::memcpy(out.data() + at + 2 * i, &h, 2);
  }
  return out;
}

size_t inspectQuantizedParameters(const uint8_t* data, size_t size, const ModelConfig& config)
{
  const GridLayout g = makeGridLayout(config.encoding); // the configuration is validated by the caller
  size_t pos = 0;
  for (int l = 0; l < g.levels; ++l)
  {
    (void)readStep(data, size, pos, l);
    pos += 4;
    try
    {
      pos += RansCoder::inspect(data + pos, size - pos, uint64_t(g.level[l].entries) * g.features);
    }
    catch (const Error& e)
    {
      corrupt("level " + std::to_string(l) + ": " + e.what());
    }
  }
  const size_t mlpBytes = 2 * mlpParameterCount(config); // at most 2 * 2^17
  if (size - pos < mlpBytes)
    corrupt("the block ends inside the MLP weights (" + std::to_string(size - pos) + " of " +
      std::to_string(mlpBytes) + " bytes)");
  return pos + mlpBytes;
}

void decodeQuantizedParameters(const uint8_t* data, size_t size, Model& model)
{
  const GridLayout& g = model.layout();
  std::vector<float>& p = model.params();
  NV_CHECK(p.size() == model.encodingParamCount() + model.mlpParamCount(), "parameter count of the model");
  std::vector<float> steps(size_t(g.levels));
  size_t pos = 0;
  for (int l = 0; l < g.levels; ++l)
  {
    const float step = readStep(data, size, pos, l);
    steps[size_t(l)] = step;
    pos += 4;
    float* out = p.data() + size_t(g.level[l].offset) * g.features;
    try
    {
      pos += RansCoder::decode(data + pos, size - pos, uint64_t(g.level[l].entries) * g.features,
        [&out, step](const uint8_t* symbols, size_t count) {
          for (size_t i = 0; i < count; ++i)
          {
            if (symbols[i] > GridQuantizer::kMaxSymbol)
              throw Error("symbol " + std::to_string(symbols[i]) + " (codes are -127 to 127)");
            out[i] = GridQuantizer::value(GridQuantizer::codeOf(symbols[i]), step);
          }
          out += count;
        });
    }
    catch (const Error& e)
    {
      corrupt("level " + std::to_string(l) + ": " + e.what());
    }
  }
  const size_t n = model.mlpParamCount();
  if (size - pos < 2 * n)
    corrupt("the block ends inside the MLP weights");
  float* mlp = p.data() + model.encodingParamCount();
  for (size_t i = 0; i < n; ++i)
  {
    uint16_t h;
    std::memcpy(&h, data + pos + 2 * i, 2);
    mlp[i] = halfToFloat(h);
  }
  pos += 2 * n;
  model.setQuantizedState(std::move(steps), int64_t(pos));
}

} // namespace nv
