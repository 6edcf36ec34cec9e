// Seed corpus of the model fuzzer: valid models of small configurations in every format version (1: no mask,
// 2: a domain mask, 3: an occupancy mask with or without a domain mask, 4: 8-bit entropy-coded parameters with any
// masks), fp32, fp16 and Quantized8, written to a folder.
// Usage: nvFuzzCorpus OUTPUT_FOLDER   (prints the number of files and their largest size)
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/Macrocells.h"
#include "Core/Serialization.h"

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

namespace
{
struct Seed
{
  const char* name;
  int levels, features, log2Table, base, finest;
  double perLevelScale;
  int width, hidden;
  nv::Precision precision;
  int64_t dims[3];
  bool domain, occupancy;
  int association;
};

nv::Model build(const Seed& s)
{
  nv::ModelConfig c;
  c.encoding.levels = s.levels;
  c.encoding.featuresPerLevel = s.features;
  c.encoding.log2TableSize = s.log2Table;
  c.encoding.baseResolution = s.base;
  c.encoding.finestResolution = s.finest;
  c.encoding.perLevelScale = s.perLevelScale;
  c.network.width = s.width;
  c.network.hiddenLayers = s.hidden;
  nv::Model m(c);
  m.initialize(uint64_t(s.levels * 131 + s.features));
  nv::SourceInfo& src = m.source;
  for (int a = 0; a < 3; ++a)
  {
    src.dims[a] = s.dims[a];
    src.spacing[a] = 0.25 * (a + 1);
    src.origin[a] = -1.5 + a;
    src.bounds[2 * a] = src.origin[a];
    src.bounds[2 * a + 1] = src.origin[a] + (s.dims[a] - 1) * src.spacing[a];
  }
  src.valueMin = -3.0;
  src.valueMax = 250.0;
  src.association = s.association;
  src.rawBytes = s.dims[0] * s.dims[1] * s.dims[2] * 4;
  src.arrayName = s.name;
  const int64_t samples = s.dims[0] * s.dims[1] * s.dims[2];
  if (s.domain)
  {
    src.domain.assign(size_t(nv::domainWords(src.dims)), 0u);
    for (int64_t i = 0; i < samples; ++i)
      if ((i / 5) % 3 != 0)
        src.domain[size_t(i >> 5)] |= 1u << (i & 31);
  }
  if (s.occupancy)
  {
    src.occupancy.assign(size_t(nv::occupancyWords(src.dims)), 0u);
    const int64_t cells = int64_t(src.occupancy.size()) * 32;
    for (int64_t k = 0; k < cells; k += 3)
      src.occupancy[size_t(k >> 5)] |= 1u << (k & 31);
    // Only the cells of the layout may carry bits (the reader rebuilds the mask from runs over them).
    const nv::MacrocellLayout layout = nv::macrocellLayout(src.dims);
    const int64_t valid = int64_t(layout.dims[0]) * layout.dims[1] * layout.dims[2];
    for (int64_t k = valid; k < cells; ++k)
      src.occupancy[size_t(k >> 5)] &= ~(1u << (k & 31));
    src.background = 0.5;
  }
  m.stats.steps = 100;
  m.stats.seconds = 1.25;
  m.stats.psnr = 30.5;
  m.stats.device = "CPU";
  m.quantize(s.precision);
  return m;
}
} // namespace

int main(int argc, char** argv)
{
  if (argc != 2)
  {
    std::fprintf(stderr, "usage: %s OUTPUT_FOLDER\n", argv[0]);
    return 2;
  }
  const nv::Precision f32 = nv::Precision::Float32, f16 = nv::Precision::Float16, q8 = nv::Precision::Quantized8;
  // Dense levels only (resolutions of a few vertices): files of a few KB, so that the fuzzer mutates headers,
  // counts and masks rather than parameters.
  const Seed seeds[] = {
    { "v1_f32", 2, 2, 10, 2, 4, 0.0, 16, 1, f32, { 5, 4, 3 }, false, false, 0 },
    { "v1_f16", 2, 4, 10, 2, 5, 0.0, 16, 2, f16, { 9, 1, 1 }, false, false, 1 },
    { "v1_scale", 3, 1, 10, 2, 0, 1.5, 16, 1, f16, { 17, 9, 2 }, false, false, 0 },
    { "v1_scale4", 2, 1, 10, 2, 0, 4.0, 16, 1, f32, { 3, 3, 3 }, false, false, 0 }, // the largest per-level scale
    { "v1_wide", 1, 8, 10, 3, 3, 0.0, 32, 1, f16, { 2, 2, 2 }, false, false, 0 },
    { "v1_hashed", 2, 1, 10, 4, 16, 0.0, 16, 1, f16, { 6, 6, 6 }, false, false, 0 }, // 17^3 > 2^10: hashed
    { "v2_domain", 2, 2, 10, 2, 4, 0.0, 16, 1, f16, { 11, 7, 5 }, true, false, 1 },
    { "v2_domain_f32", 1, 2, 10, 2, 2, 0.0, 16, 1, f32, { 40, 3, 2 }, true, false, 0 },
    { "v3_occupancy", 2, 2, 10, 2, 4, 0.0, 16, 1, f16, { 33, 20, 17 }, false, true, 0 },
    { "v3_both", 2, 1, 10, 2, 3, 0.0, 16, 2, f16, { 25, 18, 9 }, true, true, 0 },
    { "v3_flat", 1, 4, 10, 2, 2, 0.0, 16, 1, f32, { 64, 64, 1 }, false, true, 1 },
    { "v4_q8", 2, 2, 10, 2, 4, 0.0, 16, 1, q8, { 5, 4, 3 }, false, false, 0 },
    { "v4_q8_scale", 3, 1, 10, 2, 0, 1.5, 16, 1, q8, { 17, 9, 2 }, false, false, 1 },
    { "v4_q8_hashed", 2, 1, 10, 4, 16, 0.0, 16, 1, q8, { 6, 6, 6 }, false, false, 0 },
    { "v4_q8_domain", 2, 2, 10, 2, 4, 0.0, 16, 1, q8, { 11, 7, 5 }, true, false, 1 },
    { "v4_q8_both", 2, 1, 10, 2, 3, 0.0, 16, 2, q8, { 25, 18, 9 }, true, true, 0 },
  };
  try
  {
    size_t largest = 0;
    for (const Seed& s : seeds)
    {
      const std::vector<uint8_t> b = nv::serialize(build(s));
      (void)nv::deserialize(b); // every seed is valid
      const std::string path = std::string(argv[1]) + "/" + s.name + ".nvnet";
      std::FILE* f = std::fopen(path.c_str(), "wb");
      if (!f || std::fwrite(b.data(), 1, b.size(), f) != b.size() || std::fclose(f) != 0)
      {
        std::fprintf(stderr, "cannot write %s\n", path.c_str());
        return 1;
      }
      largest = b.size() > largest ? b.size() : largest;
    }
    std::printf("%zu valid models written to %s (largest %zu bytes)\n", sizeof(seeds) / sizeof(seeds[0]), argv[1],
      largest);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "nvFuzzCorpus: %s\n", e.what());
    return 1;
  }
  return 0;
}
