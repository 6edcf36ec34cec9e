// Memory estimates made before allocating (Core/ResourceEstimate.h): exact parameter counts against a constructed
// model, the batch and table terms, saturation instead of overflow, the refusal message and the grid clamp.
#include "ForkedChild.h"
#include "TestHarness.h"

#include "Core/Error.h"
#include "Core/Model.h"
#include "Core/ResourceEstimate.h"

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>

#include <sys/resource.h>

namespace
{
nv::ModelConfig smallConfig()
{
  nv::ModelConfig c;
  c.encoding.levels = 8;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = 14;
  c.encoding.finestResolution = 256;
  c.network.width = 32;
  c.network.hiddenLayers = 2;
  return c;
}
} // namespace

NV_TEST(parameter_count_matches_the_model)
{
  const nv::ModelConfig c = smallConfig();
  EXPECT_TRUE(nv::parameterCount(c) == static_cast<int64_t>(nv::Model(c).paramCount()));
  nv::ModelConfig d = c;
  d.encoding.levels = 16;
  d.encoding.featuresPerLevel = 4;
  d.network.width = 64;
  d.network.hiddenLayers = 4;
  EXPECT_TRUE(nv::parameterCount(d) == static_cast<int64_t>(nv::Model(d).paramCount()));
}

NV_TEST(training_estimate_has_the_table_and_the_batch)
{
  const nv::ModelConfig c = smallConfig();
  nv::TrainConfig t;
  t.batchSize = 1 << 20;
  const int64_t params = nv::parameterCount(c);
  const nv::MemoryEstimate e = nv::trainingMemory(c, t, nv::Device::Cpu);
  // 40 bytes per parameter, 17 + 4 D bytes per sample (D = 16 encoding outputs).
  EXPECT_TRUE(e.hostBytes == params * 40 + (int64_t(1) << 20) * (17 + 4 * 16));
  EXPECT_TRUE(e.deviceBytes == 0);
  const nv::MemoryEstimate g = nv::trainingMemory(c, t, nv::Device::Cuda, 1000);
  EXPECT_TRUE(g.deviceBytes > params * 16 + 1000);
  // The case: a 2^24 table on 16 levels to a finest resolution of 4096 holds ~595 M parameters, ~24 GB.
  nv::ModelConfig big;
  big.encoding.log2TableSize = 24;
  big.encoding.finestResolution = 4096;
  const nv::MemoryEstimate b = nv::trainingMemory(big, nv::TrainConfig(), nv::Device::Cpu);
  EXPECT_NEAR_REL(static_cast<double>(b.hostBytes), 23.8e9, 0.02, 0.0);
}

NV_TEST(saturation_instead_of_overflow)
{
  const int64_t max = std::numeric_limits<int64_t>::max();
  EXPECT_TRUE(nv::saturatingMul(int64_t(1) << 40, int64_t(1) << 40) == max);
  EXPECT_TRUE(nv::saturatingMul(-5, 7) == 0);
  EXPECT_TRUE(nv::saturatingAdd(max, 1) == max);
  const int64_t dims[3] = { 2147483647, 2147483647, 2147483647 };
  EXPECT_TRUE(nv::decodeGridMemory(dims, nv::Device::Cpu).hostBytes == max);
}

NV_TEST(refusal_names_estimate_and_limit)
{
  nv::MemoryEstimate e;
  e.hostBytes = 9400000000;
  e.detail = "a table";
  EXPECT_THROW_MSG(nv::checkMemory(e, "training this network", "Lower it", -1, 1000000000),
    "training this network needs about 9.4 GB of host memory (a table); the limit is 1 GB. Lower it.");
  nv::checkMemory(e, "training", "Lower it", -1, 9400000000); // at the limit: accepted
  e.hostBytes = 0;
  e.deviceBytes = 2000;
  EXPECT_THROW_MSG(nv::checkMemory(e, "a grid", "Lower it", 1000, 1), "of GPU memory");
  EXPECT_TRUE(nv::physicalMemoryBytes() > 0);
  EXPECT_TRUE(nv::hostMemoryLimit() < nv::physicalMemoryBytes());
}

NV_TEST(grid_clamp_keeps_proportions)
{
  int64_t out[3];
  const int64_t fits[3] = { 100, 200, 300 };
  EXPECT_TRUE(!nv::clampGrid(fits, 6000000, out) && out[0] == 100 && out[1] == 200 && out[2] == 300);
  const int64_t big[3] = { 4096, 4096, 4096 };
  EXPECT_TRUE(nv::clampGrid(big, int64_t(1) << 31, out));
  EXPECT_TRUE(out[0] == 1290 && out[1] == 1290 && out[2] == 1290);
  const int64_t flat[3] = { 2048, 2048, 1024 };
  EXPECT_TRUE(nv::clampGrid(flat, int64_t(1) << 31, out));
  EXPECT_TRUE(out[0] * out[1] * out[2] <= (int64_t(1) << 31) && std::llabs(out[0] - 2 * out[2]) <= 2 && out[0] == out[1] && out[0] >= 1600);
  const int64_t line[3] = { 8192, 1, 1 };
  EXPECT_TRUE(nv::clampGrid(line, 100, out) && out[0] == 100 && out[1] == 1 && out[2] == 1);
}

NV_TEST(decode_grid_fits_the_machine)
{
  nv::SourceInfo src;
  src.dims[0] = 64;
  src.dims[1] = 32;
  src.dims[2] = 16;
  int used[3] = { -1, -1, -1 };
  const int trained[3] = { 0, 0, 0 };
  EXPECT_TRUE(nv::fitDecodeGrid(src, nv::Device::Cpu, trained, used).empty());
  EXPECT_TRUE(used[0] == 0 && used[1] == 0 && used[2] == 0); // the source's dims, unclamped
  const int small[3] = { 100, 50, 25 };
  EXPECT_TRUE(nv::fitDecodeGrid(src, nv::Device::Cpu, small, used).empty());
  EXPECT_TRUE(used[0] == 100 && used[1] == 50 && used[2] == 25);
  const int huge[3] = { 4096, 4096, 4096 }; // 2^36 samples: above 2^31 on any machine
  const std::string why = nv::fitDecodeGrid(src, nv::Device::Cpu, huge, used);
  EXPECT_TRUE(!why.empty());
  EXPECT_TRUE(used[0] == used[1] && used[1] == used[2] && used[0] > 0);
  EXPECT_TRUE(int64_t(used[0]) * used[1] * used[2] <= nv::kMaxDecodeGridSamples);
  const int wide[3] = { 100000, 2, 2 }; // beyond the per-axis cap
  EXPECT_TRUE(!nv::fitDecodeGrid(src, nv::Device::Cpu, wide, used).empty());
  EXPECT_TRUE(used[0] == nv::kMaxDecodeResolution && used[1] == 2 && used[2] == 2);
}

NV_TEST(budget_follows_the_process_limits)
{
  const int64_t gb = 1000000000;
  nv::ProcessMemoryLimits none; // unlimited: the physical memory's share
  const nv::HostMemoryBudget physical = nv::hostMemoryBudget(&none);
  EXPECT_TRUE(physical.bytes == static_cast<int64_t>(static_cast<double>(nv::physicalMemoryBytes()) * 0.8));
  EXPECT_TRUE(physical.reason.find("80% of this machine's") == 0);
  nv::ProcessMemoryLimits as;
  as.addressSpace = 16 * gb;
  as.addressSpaceUsed = 3 * gb;
  const nv::HostMemoryBudget b = nv::hostMemoryBudget(&as);
  EXPECT_TRUE(b.bytes == std::min<int64_t>(13 * gb, physical.bytes));
  if (b.bytes == 13 * gb)
    EXPECT_TRUE(b.reason == "the process may use at most 16 GB (ulimit -v), 3 GB of it already in use");
  nv::ProcessMemoryLimits data;
  data.data = 2 * gb;
  data.dataUsed = 500000000;
  const nv::HostMemoryBudget d = nv::hostMemoryBudget(&data);
  EXPECT_TRUE(d.bytes == 1500000000 && d.reason.find("(ulimit -d)") != std::string::npos);
  data.dataUsed = 3 * gb; // more in use than the limit: nothing left, not a negative budget
  EXPECT_TRUE(nv::hostMemoryBudget(&data).bytes == 0);
}

NV_TEST(refusal_under_a_lowered_address_space_limit)
{
  if (nvtest::skipAddressSpaceLimits())
    return;
  // In a child: RLIMIT_AS at what the process uses + 1 GB. The budget is that gigabyte (less what the statm read
  // itself maps), the refusal names "ulimit -v", and a real allocation of 2 GB fails as the estimate said.
  const int rc = nvtest::runInChild(
    [] {
      const int64_t gb = 1000000000;
      const nv::ProcessMemoryLimits before = nv::processMemoryLimits();
      struct rlimit r;
      getrlimit(RLIMIT_AS, &r);
      r.rlim_cur = static_cast<rlim_t>(before.addressSpaceUsed + gb);
      if (setrlimit(RLIMIT_AS, &r) != 0)
        return 10;
      const nv::HostMemoryBudget b = nv::hostMemoryBudget();
      std::printf("    budget %s (%s)\n", nv::formatBytes(b.bytes).c_str(), b.reason.c_str());
      if (b.bytes > gb || b.bytes < gb * 9 / 10 || nv::hostMemoryLimit() != b.bytes)
        return 11;
      if (b.reason.find("the process may use at most") != 0 || b.reason.find("(ulimit -v)") == std::string::npos)
        return 12;
      nv::MemoryEstimate e;
      e.hostBytes = 2 * gb;
      e.detail = "a test";
      try
      {
        nv::checkMemory(e, "a decode", "Lower it");
        return 13;
      }
      catch (const nv::Error& error)
      {
        std::printf("    %s\n", error.what());
        if (std::string(error.what()).find("(ulimit -v)") == std::string::npos)
          return 14;
      }
      try
      {
        std::string big(static_cast<size_t>(2 * gb), 'x'); // what the check spared the caller
        return big.size() == 0 ? 15 : 16;
      }
      catch (const std::bad_alloc&)
      {
      }
      return 0;
    },
    60.0);
  EXPECT_TRUE(rc == 0);
}

NV_TEST(decode_grid_within_what_the_network_resolves)
{
  nv::EncodingConfig e;
  e.levels = 8;
  e.baseResolution = 16;
  e.finestResolution = 128;
  const int resolved = nv::resolvedSamplesPerAxis(e);
  EXPECT_TRUE(resolved >= 128 && resolved <= 129);
  nv::SourceInfo src;
  src.dims[0] = src.dims[1] = src.dims[2] = 64;
  int used[3];
  const int cube[3] = { 4096, 4096, 4096 };
  const std::string why = nv::fitDecodeGrid(src, nv::Device::Cpu, cube, used, resolved);
  EXPECT_TRUE(why.find("finer than the network resolves") == 0);
  const int most = resolved * nv::kDecodeOversampling;
  EXPECT_TRUE(used[0] == most && used[1] == most && used[2] == most);
  const int slab[3] = { 65536, 65536, 2 };
  EXPECT_TRUE(!nv::fitDecodeGrid(src, nv::Device::Cpu, slab, used, resolved).empty());
  EXPECT_TRUE(used[0] == most && used[1] == most && used[2] == 2);
  src.dims[0] = 300; // the source's own samples are never cut
  const int source[3] = { 300, most, 100 };
  EXPECT_TRUE(nv::fitDecodeGrid(src, nv::Device::Cpu, source, used, resolved).empty());
  EXPECT_TRUE(used[0] == 300 && used[1] == most && used[2] == 100);
}

NV_TEST_MAIN()
