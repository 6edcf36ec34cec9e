// Seed corpus of the OpenVDB header fuzzer (nvFuzzVdbFile): valid .vdb layouts (Testing/Engine/SyntheticVdb.h) of
// every format version the check reads (213 to 224: without instances, with the 16-byte UUID, the 'compressed' flag,
// per-grid compression), with grid offsets and streamed, with one to three grids (half float, an instance), written
// to a folder; each is checked (valid) before it is written.
// Usage: nvFuzzVdbCorpus OUTPUT_FOLDER   (prints the number of files and their largest size)
#include "Core/VdbFileCheck.h"
#include "SyntheticVdb.h"

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

namespace
{
nvtest::SyntheticVdb layout(uint32_t version, int grids, bool offsets)
{
  nvtest::SyntheticVdb v;
  v.version = version;
  v.hasGridOffsets = offsets;
  v.grids.resize(size_t(grids));
  if (grids > 1)
  {
    v.grids[1].name = "temperature";
    v.grids[1].halfFloat = true;
    v.grids[1].type = "Tree_double_5_4_3";
  }
  if (grids > 2 && version >= 216)
  {
    v.grids[2].name = "density_copy";
    v.grids[2].instanceParent = "density";
  }
  return v;
}
} // namespace

int main(int argc, char** argv)
{
  if (argc != 2)
  {
    std::fprintf(stderr, "usage: %s OUTPUT_FOLDER\n", argv[0]);
    return 2;
  }
  struct Seed
  {
    const char* name;
    uint32_t version;
    int grids;
    bool offsets;
  };
  const Seed seeds[] = { { "v224_one", 224, 1, true }, { "v224_three", 224, 3, true }, { "v224_none", 224, 0, true },
    { "v224_streamed", 224, 2, false }, { "v222_two", 222, 2, true }, { "v221_compressed_flag", 221, 2, true },
    { "v219_three", 219, 3, true }, { "v217_uuid16", 217, 3, true }, { "v213_oldest", 213, 2, true } };
  try
  {
    size_t largest = 0;
    for (const Seed& s : seeds)
    {
      const std::vector<uint8_t> b = layout(s.version, s.grids, s.offsets).build();
      (void)nv::VdbFileCheck::checkBytes(b.data(), b.size()); // every seed is valid
      const std::string path = std::string(argv[1]) + "/" + s.name + ".vdb";
      std::FILE* f = std::fopen(path.c_str(), "wb");
      if (!f || std::fwrite(b.data(), 1, b.size(), f) != b.size() || std::fclose(f) != 0)
      {
        std::fprintf(stderr, "cannot write %s\n", path.c_str());
        return 1;
      }
      largest = b.size() > largest ? b.size() : largest;
    }
    std::printf("%zu valid .vdb layouts written to %s (largest %zu bytes)\n", sizeof(seeds) / sizeof(seeds[0]),
      argv[1], largest);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "nvFuzzVdbCorpus: %s\n", e.what());
    return 1;
  }
  return 0;
}
