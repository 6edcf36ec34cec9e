// Hash-grid indexing and encoding against the brute-force double-precision reference.
#include "Core/Engine.h"
#include "Cpu/CpuHashGrid.h"
#include "Reference.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <random>

using namespace nv;
using nvtest::compareToSource;
using nvtest::createTrainer;
using nvtest::decodeGrid;
using nvtest::decodeGridNormalized;
using nvtest::inferPoints;

NV_TEST(layout_matches_reference_paper_config)
{
  EncodingConfig e; // paper: 16 x 4, 2^19, base 16, finest 4096
  const GridLayout g = makeGridLayout(e);
  const auto r = nvtest::refLevels(e);
  EXPECT_TRUE(g.levels == 16);
  for (int l = 0; l < 16; ++l)
  {
    EXPECT_TRUE(g.level[l].res == r[l].res);
    EXPECT_TRUE(g.level[l].entries == r[l].entries);
    EXPECT_TRUE(g.level[l].offset == r[l].offset);
    EXPECT_TRUE((g.level[l].hashed != 0) == r[l].hashed);
  }
  // Known values: level 0 is 16^3 dense (scale 15 -> res 16), the finest is hashed with 2^19 entries.
  EXPECT_TRUE(g.level[0].res == 16 && g.level[0].entries == 4096 && !g.level[0].hashed);
  EXPECT_TRUE(g.level[15].hashed && g.level[15].entries == (1u << 19));
  EXPECT_TRUE(g.level[15].res == 4096);
}

NV_TEST(indices_match_bruteforce_dense_and_hashed)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int log2T : { 12, 14, 19 })
  {
    EncodingConfig e;
    e.log2TableSize = log2T;
    e.finestResolution = 512;
    const GridLayout g = makeGridLayout(e);
    const auto r = nvtest::refLevels(e);
    int hashedSeen = 0, denseSeen = 0;
    for (int l = 0; l < e.levels; ++l)
    {
      (g.level[l].hashed ? hashedSeen : denseSeen)++;
      for (int k = 0; k < 2000; ++k)
      {
        const uint32_t c[3] = { uint32_t(u(rng) * r[l].res), uint32_t(u(rng) * r[l].res), uint32_t(u(rng) * r[l].res) };
        for (int corner = 0; corner < 8; ++corner)
        {
          const uint64_t ref = nvtest::refIndex(r[l], c[0] + (corner & 1), c[1] + ((corner >> 1) & 1), c[2] + ((corner >> 2) & 1));
          if (cornerIndex(g.level[l], corner, c) != ref)
          {
            nvtest::fail(__FILE__, __LINE__, "index mismatch at level " + std::to_string(l));
            return;
          }
        }
      }
    }
    EXPECT_TRUE(hashedSeen > 0 && denseSeen > 0);
  }
}

NV_TEST(encoding_matches_reference_all_feature_counts)
{
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int F : { 1, 2, 4, 8 })
  {
    ModelConfig c;
    c.encoding.levels = 8;
    c.encoding.featuresPerLevel = F;
    c.encoding.log2TableSize = 12;
    c.encoding.finestResolution = 256;
    Model m(c);
    m.initialize(3);
    for (float& p : m.params())
      p = u(rng) * 2 - 1; // large values so that errors are visible
    std::vector<double> table(m.params().begin(), m.params().end());
    const int n = 500;
    std::vector<float> xyz(3 * n);
    for (float& x : xyz)
      x = u(rng);
    std::vector<float> out(size_t(n) * c.encoding.outputDims());
    CpuHashGrid::encode(m.layout(), m.params().data(), xyz.data(), n, out.data());
    double maxErr = 0;
    for (int s = 0; s < n; ++s)
    {
      const double x[3] = { xyz[3 * s], xyz[3 * s + 1], xyz[3 * s + 2] };
      const auto ref = nvtest::refEncode(m, table, x);
      for (size_t j = 0; j < ref.size(); ++j)
        maxErr = std::max(maxErr, std::fabs(ref[j] - out[s * ref.size() + j]));
    }
    // fp32 position (ulp ~1.5e-5 at scale 255, FMA or not) times O(1) feature differences.
    EXPECT_TRUE(maxErr < 1e-4);
  }
}

NV_TEST(inference_matches_reference_forward)
{
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int width : { 16, 32, 64, 128 })
    for (int hidden : { 1, 3, 8 })
    {
      ModelConfig c;
      c.encoding.levels = 6;
      c.encoding.featuresPerLevel = 2;
      c.encoding.log2TableSize = 12;
      c.encoding.finestResolution = 128;
      c.network.width = width;
      c.network.hiddenLayers = hidden;
      Model m(c);
      m.initialize(width + hidden);
      for (size_t i = 0; i < m.encodingParamCount(); ++i)
        m.params()[i] = u(rng) - 0.5f;
      const int n = 200;
      std::vector<float> xyz(3 * n), out(n);
      for (float& x : xyz)
        x = u(rng);
      inferPoints(m, xyz.data(), n, out.data(), Device::Cpu, 2);
      std::vector<double> p(m.params().begin(), m.params().end());
      double num = 0, den = 0;
      for (int s = 0; s < n; ++s)
      {
        const double x[3] = { xyz[3 * s], xyz[3 * s + 1], xyz[3 * s + 2] };
        const double ref = nvtest::refForward(m, p, x);
        num += (out[s] - ref) * (out[s] - ref);
        den += ref * ref;
      }
      EXPECT_TRUE(den > 0 && std::sqrt(num / den) < 1e-5);
    }
}

NV_TEST(decode_equals_inference_on_grid_points)
{
  ModelConfig c;
  c.encoding.levels = 4;
  c.encoding.log2TableSize = 10;
  c.encoding.finestResolution = 64;
  c.network.width = 16;
  c.network.hiddenLayers = 2;
  Model m(c);
  m.initialize(9);
  for (size_t i = 0; i < m.encodingParamCount(); ++i)
    m.params()[i] = float(std::sin(0.37 * i));
  m.source.valueMin = -3.0;
  m.source.valueMax = 5.0;
  const int nx = 7, ny = 5, nz = 4;
  std::vector<float> grid(nx * ny * nz), xyz, pts;
  decodeGrid(m, nx, ny, nz, 0, nz, grid.data(), Device::Cpu, 2);
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
      {
        xyz.push_back(float(double(x) / (nx - 1)));
        xyz.push_back(float(double(y) / (ny - 1)));
        xyz.push_back(float(double(z) / (nz - 1)));
      }
  pts.resize(grid.size());
  inferPoints(m, xyz.data(), int64_t(pts.size()), pts.data(), Device::Cpu, 1);
  for (size_t i = 0; i < grid.size(); ++i)
    EXPECT_TRUE(grid[i] == float(-3.0 + 8.0 * pts[i]));
  // A slab decodes to the same values as the whole grid.
  std::vector<float> slab(nx * ny * 2);
  decodeGrid(m, nx, ny, nz, 1, 3, slab.data(), Device::Cpu, 1);
  for (size_t i = 0; i < slab.size(); ++i)
    EXPECT_TRUE(slab[i] == grid[nx * ny + i]);
}

NV_TEST(invalid_configurations_are_rejected)
{
  ModelConfig c;
  c.encoding.featuresPerLevel = 3;
  EXPECT_THROW_MSG(Model m(c), "features per level");
  c = ModelConfig();
  c.network.width = 48;
  EXPECT_THROW_MSG(Model m(c), "network width");
  c = ModelConfig();
  c.network.hiddenLayers = 9;
  EXPECT_THROW_MSG(Model m(c), "hidden layers");
  c = ModelConfig();
  c.encoding.log2TableSize = 30;
  EXPECT_THROW_MSG(Model m(c), "log2 table size");
}

NV_TEST_MAIN()
