// Issue 22's PSNR gap at the engine level: one volume file trained in memory (the whole file loaded, host-sampled on
// CUDA) and out of core (the random block buffer of Cuda/OutOfCore under a budget), the same network, seed, batch and
// schedule, both measured exactly over every voxel of the file. One JSON line per run: PSNR, steps/s, the buffer's
// blocks (resident, read, swapped, swaps missed), the share of the volume's blocks it has held (coverage) and its read
// throughput while training (the bytes its blocks hold, read after the first fill, over the training seconds).
//   nvBenchOutOfCoreGap FILE.nhdr [key=value ...]
// keys: mode=both|memory|ooc steps=3000 batch=4096 log2=16 levels=16 features=2 finest=0 (0: twice the largest
// dimension) width=32 layers=2 device=cpu|cuda threads=2 seed=5 budget_mib=16 (the block buffer's bytes) edge=0 (cells
// per block edge; 0: the filter's choice) per_step=0 (blocks replaced a step; 0: the filter's choice) readers=4
// cache=0 (1: O_DIRECT, 2: drop behind: nv::PageCacheUse) edge_x=0 (cells along x; 0: edge) nice=0 (the readers' nice
// increment; device=cuda: 10, as the filter's)
#include "OutOfCore/BlockBufferSource.h"
#include "OutOfCore/FileMeasure.h"
#include "SessionHelpers.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

namespace
{
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0)
{
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Options
{
  std::map<std::string, std::string> values;
  double number(const std::string& key, double fallback) const
  {
    auto found = values.find(key);
    return found == values.end() ? fallback : std::atof(found->second.c_str());
  }
  std::string text(const std::string& key, const std::string& fallback) const
  {
    auto found = values.find(key);
    return found == values.end() ? fallback : found->second;
  }
};

nv::ModelConfig modelOf(const Options& o, const nv::VolumeFileLayout& layout)
{
  nv::ModelConfig c;
  c.encoding.levels = int(o.number("levels", 16));
  c.encoding.featuresPerLevel = int(o.number("features", 2));
  c.encoding.log2TableSize = int(o.number("log2", 16));
  const int64_t largest = std::max({ layout.dims[0], layout.dims[1], layout.dims[2] });
  c.encoding.finestResolution = int(o.number("finest", 0)) > 0 ? int(o.number("finest", 0)) : int(2 * largest);
  c.network.width = int(o.number("width", 32));
  c.network.hiddenLayers = int(o.number("layers", 2));
  return c;
}

nv::TrainConfig trainOf(const Options& o, int steps)
{
  nv::TrainConfig t;
  t.batchSize = int(o.number("batch", 4096));
  t.seed = uint64_t(o.number("seed", 5));
  t.threads = int(o.number("threads", 2));
  t.strategy = nv::TrainingStrategy::HostSampled;
  t.optimizer.plannedSteps = steps; // the filter's TrainingSteps run: the cosine anneal over the run
  return t;
}

nv::Device deviceOf(const Options& o)
{
  return o.text("device", "cpu") == "cuda" ? nv::Device::Cuda : nv::Device::Cpu;
}

/// The filter's block edge and blocks a step (vtkNeuralOutOfCoreInput.cxx) unless given.
void blockPolicy(const Options& o, int64_t bufferBytes, int batch, nv::BlockBufferConfig& config)
{
  config.blockCells = int(o.number("edge", 0));
  if (config.blockCells <= 0)
  {
    config.blockCells = 2;
    for (int edge = 32; edge > 2; --edge)
      if (double(bufferBytes) / double(nv::BlockBuffer::bytesPerSlot(edge)) >= 32.0 * batch)
      {
        config.blockCells = edge;
        break;
      }
  }
  const int64_t side = config.blockCells + 1;
  const int64_t slots = bufferBytes / nv::BlockBuffer::bytesPerSlot(config.blockCells);
  int64_t perStep = int64_t(o.number("per_step", 0));
  if (perStep <= 0)
    perStep = std::max<int64_t>(16, 32768 / (side * side));
  config.loadingSlots = int(std::max<int64_t>(2, std::min(2 * perStep, slots / 4)));
}

void printRun(const char* mode, const nv::ErrorStats& e, int steps, double trainingSeconds, double extraSeconds)
{
  std::printf("{\"mode\": \"%s\", \"psnr\": %.4f, \"steps\": %d, \"training_s\": %.3f, \"steps_per_s\": %.2f, "
              "\"other_s\": %.2f", mode, e.psnr, steps, trainingSeconds, steps / trainingSeconds, extraSeconds);
}

void runMemory(const Options& o, const nv::VolumeFileLayout& layout, const nv::FileValueRange& range, int steps)
{
  nv::VolumeFileReader reader(layout);
  std::vector<float> values(size_t(layout.samples()));
  const auto t0 = Clock::now();
  reader.readBox({ 0, 0, 0 }, { layout.dims[0], layout.dims[1], layout.dims[2] }, values.data());
  nv::VolumeView view;
  view.data = values.data();
  view.type = nv::ScalarType::Float32;
  std::copy(layout.dims, layout.dims + 3, view.dims);
  view.valueMin = range.min;
  view.valueMax = range.max;
  const double loadSeconds = since(t0);
  const nv::Model initial = nvtest::untrainedModel(modelOf(o, layout), view, 7);
  nvtest::SessionTrainer trainer = nvtest::createTrainer(deviceOf(o), initial, view, trainOf(o, steps));
  const auto t1 = Clock::now();
  for (int s = 0; s < steps; ++s)
    trainer->step();
  trainer->publish();
  const double trainingSeconds = since(t1);
  const nv::ErrorStats e = nv::compareToSource(*trainer.s, view);
  printRun("memory", e, steps, trainingSeconds, loadSeconds);
  std::printf("}\n");
  std::fflush(stdout);
}

void runOutOfCore(const Options& o, const nv::VolumeFileLayout& layout, const nv::FileValueRange& range, int steps)
{
  nv::BlockBufferConfig config;
  config.memoryBudgetBytes = int64_t(o.number("budget_mib", 16) * 1048576.0);
  config.readerThreads = int(o.number("readers", 4));
  config.readerNice = int(o.number("nice", o.values.count("device") && o.values.at("device") == "cuda" ? 10 : 0));
  config.seed = uint64_t(o.number("seed", 5));
  config.pageCache = static_cast<nv::PageCacheUse>(int(o.number("cache", 0)));
  config.trackCoverage = true;
  config.blockCellsX = int(o.number("edge_x", 0));
  const nv::TrainConfig train = trainOf(o, steps);
  blockPolicy(o, config.memoryBudgetBytes, train.batchSize, config);
  const auto t0 = Clock::now();
  nv::BlockBuffer buffer(layout, config);
  const double fillSeconds = since(t0);
  const int64_t firstFillBytes = buffer.stats().bytesRead;
  nv::BlockBufferSource source(buffer, nv::ValueRange(range.min, range.max), config.loadingSlots / 2);
  nv::VolumeView rangeView;
  rangeView.valueMin = range.min;
  rangeView.valueMax = range.max;
  const nv::Model initial = nvtest::untrainedModel(modelOf(o, layout), rangeView, 7);
  auto session = nvtest::session(initial, deviceOf(o), train.threads);
  auto trainer = session->createTrainer(source, train);
  const auto t1 = Clock::now();
  for (int s = 0; s < steps; ++s)
    trainer->step();
  trainer->publish();
  const double trainingSeconds = since(t1);
  const nv::BlockBufferStats stats = buffer.stats();
  nv::VolumeFileReader reader(layout);
  const nv::ErrorStats e = nv::measureOnFile(*session, reader, range.min, range.max, int64_t(64) << 20);
  printRun("ooc", e, steps, trainingSeconds, fillSeconds);
  std::printf(", \"edge\": %d, \"per_step\": %d, \"resident_blocks\": %lld, \"block_count\": %lld, "
              "\"resident_share\": %.4f, \"blocks_read\": %lld, \"swapped\": %lld, \"swaps_missed\": %lld, "
              "\"coverage\": %.4f, \"read_mb_per_s\": %.2f, \"training_read_mb_per_s\": %.3f, "
              "\"transferred_mb\": %.1f, \"cache\": %d, \"edge_x\": %d}\n",
    config.blockCells, config.loadingSlots / 2, (long long)stats.residentBlocks, (long long)stats.blockCount,
    double(stats.residentBlocks) / double(stats.blockCount), (long long)stats.blocksRead,
    (long long)stats.blocksSwapped, (long long)stats.swapsMissed, stats.blocksEverResident / double(stats.blockCount),
    double(stats.bytesRead) / 1e6 / (fillSeconds + trainingSeconds),
    double(stats.bytesRead - firstFillBytes) / 1e6 / trainingSeconds, double(stats.bytesTransferred) / 1e6,
    int(stats.pageCache), stats.blockCells[0]);
  std::fflush(stdout);
}
} // namespace

int main(int argc, char** argv)
{
  if (argc < 2)
  {
    std::fprintf(stderr, "usage: %s FILE.nhdr [key=value ...] (see the source's header)\n", argv[0]);
    return 2;
  }
  Options o;
  for (int k = 2; k < argc; ++k)
  {
    const std::string item = argv[k];
    const size_t eq = item.find('=');
    if (eq == std::string::npos)
    {
      std::fprintf(stderr, "not key=value: %s\n", argv[k]);
      return 2;
    }
    o.values[item.substr(0, eq)] = item.substr(eq + 1);
  }
  try
  {
    const nv::VolumeFileLayout layout = nv::readVolumeFileLayout(argv[1]);
    nv::VolumeFileReader reader(layout);
    const nv::FileValueRange range = nv::scanValueRange(reader, int64_t(64) << 20);
    const int steps = int(o.number("steps", 3000));
    const std::string mode = o.text("mode", "both");
    if (mode == "both" || mode == "memory")
      runMemory(o, layout, range, steps);
    if (mode == "both" || mode == "ooc")
      runOutOfCore(o, layout, range, steps);
  }
  catch (const std::exception& error)
  {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
  return 0;
}
