// Out-of-core training (issue 22), the engine's part: a network trained from a volume file through the random block
// buffer with every block resident reaches the PSNR of the same training from memory within 1.5 dB; with a quarter
// of the bytes it trains (the gap recorded); the streamed measurement of a network over the file equals the in-memory
// one to 1e-6 dB; the streamed value range is the field's; a stopped pass stops; a sub-box of the file (one MPI
// rank's piece) reads and measures only its samples.   nvTestOutOfCore [case]
#include "Core/Error.h"
#include "MirrorBatchSource.h"
#include "OutOfCore/BlockBufferSource.h"
#include "OutOfCore/FileMeasure.h"
#include "SessionHelpers.h"
#include "TempFolder.h"
#include "TestHarness.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <cstdlib>
#include <fstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace
{
constexpr int kSide = 40;

std::string tempDir()
{
  return nvtest::tempFolder();
}

/// A smooth field with structure at a few scales, 40^3 float32, as memory and as a .nhdr file.
std::vector<float> field()
{
  return nvtest::sampledCube(kSide, [](double x, double y, double z) {
    return std::sin(6.0 * x) * std::cos(4.0 * y) + 0.5 * std::sin(11.0 * z + 3.0 * x) + 0.25 * std::cos(17.0 * y * z);
  });
}

nv::VolumeFileLayout writeField(const std::vector<float>& values)
{
  std::ofstream raw(tempDir() + "/f.raw", std::ios::binary);
  raw.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(float)));
  raw.close();
  std::ofstream header(tempDir() + "/f.nhdr");
  header << "NRRD0004\ntype: float\ndimension: 3\nsizes: " << kSide << " " << kSide << " " << kSide
         << "\nencoding: raw\nendian: little\ndata file: f.raw\n";
  header.close();
  return nv::readVolumeFileLayout(tempDir() + "/f.nhdr");
}

nv::TrainConfig trainConfig()
{
  nv::TrainConfig c;
  c.batchSize = 8192;
  c.seed = 3;
  c.threads = 2;
  return c;
}
} // namespace

namespace
{
struct Trained
{
  nv::ErrorStats figures;
  nv::BlockBufferStats buffer;
};

/// `steps` steps from the file through a block buffer of `budget` bytes (8-cell blocks, `blocksPerStep` swapped in
/// per step), measured over the whole file.
Trained trainFromFile(const nv::VolumeFileLayout& layout, const nv::Model& initial, int64_t budget, int blocksPerStep,
  int steps)
{
  nv::VolumeFileReader reader(layout);
  const nv::FileValueRange range = nv::scanValueRange(reader, 64 << 10);
  nv::BlockBufferConfig config;
  config.blockCells = 8;
  config.readerThreads = 2;
  config.memoryBudgetBytes = budget;
  nv::BlockBuffer buffer(layout, config);
  nv::BlockBufferSource source(buffer, nv::ValueRange(range.min, range.max), blocksPerStep);
  auto session = nvtest::session(initial, nv::Device::Cpu, 2);
  nv::TrainConfig train = trainConfig();
  train.optimizer.plannedSteps = steps;
  auto trainer = session->createTrainer(source, train);
  for (int s = 0; s < steps; ++s)
    trainer->step();
  trainer->publish();
  Trained result{ nv::measureOnFile(*session, reader, range.min, range.max, 100 << 10), buffer.stats() };
  EXPECT_TRUE(result.buffer.bufferBytes <= budget);
  return result;
}

nv::ErrorStats trainInMemory(const nv::VolumeView& view, const nv::Model& initial, int steps,
  const nv::VolumeFileLayout* alsoStreamed)
{
  nv::TrainConfig train = trainConfig();
  train.optimizer.plannedSteps = steps;
  nvtest::SessionTrainer memory = nvtest::createTrainer(nv::Device::Cpu, initial, view, train);
  for (int s = 0; s < steps; ++s)
    memory->step();
  memory->publish();
  const nv::ErrorStats inMemory = nv::compareToSource(*memory.s, view);
  if (alsoStreamed)
  {
    // The same network measured by the streamed pass over the file: the same figures.
    nv::VolumeFileReader reader(*alsoStreamed);
    const nv::ErrorStats streamed = nv::measureOnFile(*memory.s, reader, view.valueMin, view.valueMax, 100 << 10);
    std::printf("  in memory: %.6f dB measured in memory, %.6f dB streamed from the file (slabs of 100 KiB)\n",
      inMemory.psnr, streamed.psnr);
    EXPECT_NEAR_REL(streamed.psnr, inMemory.psnr, 0.0, 1e-6);
    EXPECT_NEAR_REL(streamed.maxAbsError, inMemory.maxAbsError, 1e-9, 1e-9);
    EXPECT_TRUE(streamed.count == inMemory.count);
  }
  return inMemory;
}
} // namespace

NV_TEST(out_of_core_training_with_the_volume_resident_matches_memory)
{
  const std::vector<float> values = field();
  const nv::VolumeView view = nvtest::cubeView(values, kSide);
  const nv::VolumeFileLayout layout = writeField(values);
  nv::VolumeFileReader reader(layout);
  const nv::FileValueRange scanned = nv::scanValueRange(reader, 64 << 10);
  EXPECT_TRUE(scanned.min == view.valueMin && scanned.max == view.valueMax && scanned.finite == kSide * kSide * kSide);
  const nv::Model initial = nvtest::untrainedModel(nvtest::smallModelConfig(14), view, 5);
  const nv::ErrorStats inMemory = trainInMemory(view, initial, 300, &layout);
  const Trained resident = trainFromFile(layout, initial, int64_t(64) << 20, 4, 300);
  std::printf("  every block resident: %.3f dB after 300 steps (in memory %.3f dB), %lld blocks read\n",
    resident.figures.psnr, inMemory.psnr, (long long)resident.buffer.blocksRead);
  EXPECT_TRUE(resident.buffer.residentBlocks == 125 && resident.buffer.blocksRead == 125);
  EXPECT_TRUE(std::isfinite(resident.figures.psnr) && std::fabs(resident.figures.psnr - inMemory.psnr) <= 1.5);
}

NV_TEST(out_of_core_training_from_a_quarter_of_the_volume)
{
  // A quarter of the field's bytes: 16 of its 125 blocks resident at a time. Measured (2 cores): 50.2-51.1 dB after
  // 1500 steps against 56.2 dB in memory -- the gap of a partly resident field, recorded; the bound below is far
  // above what misplaced samples give (< 30 dB).
  const std::vector<float> values = field();
  const nv::VolumeView view = nvtest::cubeView(values, kSide);
  const nv::VolumeFileLayout layout = writeField(values);
  const nv::Model initial = nvtest::untrainedModel(nvtest::smallModelConfig(14), view, 5);
  const int64_t budget = static_cast<int64_t>(values.size() * sizeof(float)) / 4;
  const Trained quarter = trainFromFile(layout, initial, budget, 8, 1500);
  std::printf("  a quarter of the bytes: %.3f dB after 1500 steps; %lld blocks resident, %lld read, %lld swapped, "
              "%lld swaps missed, buffer %lld of %lld bytes\n", quarter.figures.psnr,
    (long long)quarter.buffer.residentBlocks, (long long)quarter.buffer.blocksRead,
    (long long)quarter.buffer.blocksSwapped, (long long)quarter.buffer.swapsMissed,
    (long long)quarter.buffer.bufferBytes, (long long)budget);
  EXPECT_TRUE(quarter.buffer.residentBlocks < 32 && quarter.buffer.blocksSwapped > 1000);
  EXPECT_TRUE(std::isfinite(quarter.figures.psnr) && quarter.figures.psnr >= 45.0);
}

NV_TEST(a_batch_source_trains_as_the_volume_it_mirrors)
{
  // The trainer's batch-source path: fed what the volume trainer draws, it trains the same network bit for bit.
  const std::vector<float> values = field();
  const nv::VolumeView view = nvtest::cubeView(values, kSide);
  const nv::Model initial = nvtest::untrainedModel(nvtest::smallModelConfig(12), view, 2);
  nvtest::SessionTrainer direct = nvtest::createTrainer(nv::Device::Cpu, initial, view, trainConfig());
  nvtest::MirrorBatchSource mirror(view);
  auto session = nvtest::session(initial, nv::Device::Cpu, 2);
  auto fed = session->createTrainer(mirror, trainConfig());
  for (int s = 0; s < 40; ++s)
    EXPECT_TRUE(direct->step() == fed->step());
  nv::Model a = initial, b = initial;
  direct->syncTo(a);
  fed->syncTo(b);
  EXPECT_TRUE(a.params() == b.params());
  EXPECT_TRUE(mirror.Prepared == 40 && mirror.LastStep == 40);
}

NV_TEST(a_stopped_pass_stops)
{
  const nv::VolumeFileLayout layout = writeField(field());
  nv::VolumeFileReader reader(layout);
  int slabs = 0;
  EXPECT_THROW_MSG(nv::scanValueRange(reader, 32 << 10, [&](double) { return ++slabs < 2; }), "stopped");
  EXPECT_TRUE(slabs == 2);
}

NV_TEST(a_sub_box_reads_and_measures_only_its_samples)
{
  // One MPI rank's piece of a file (VolumeFileLayout::boxOrigin): its readers see only the box, every read lands in
  // it (the tally's box), a box of a box composes, and the measurement of a box adds up to the whole's.
  const std::vector<float> values = field();
  const nv::VolumeFileLayout layout = writeField(values);
  const int64_t origin[3] = { 5, 7, 9 }, size[3] = { 20, 17, 13 };
  nv::VolumeFileLayout box = nv::volumeFileSubBox(layout, origin, size);
  box.readTally = std::make_shared<nv::FileReadTally>();
  EXPECT_TRUE(box.dims[0] == 20 && box.fileDim(0) == kSide && box.bytes() == 20 * 17 * 13 * 4 &&
    box.fileBytes() == layout.bytes());
  nv::VolumeFileReader reader(box);
  const nv::FileValueRange range = nv::scanValueRange(reader, 4 << 10); // slabs of one plane
  std::vector<float> read(static_cast<size_t>(box.samples()));
  reader.readBox({ 0, 0, 0 }, { 20, 17, 13 }, read.data());
  double lo = 1e300, hi = -1e300;
  bool same = true;
  for (int64_t z = 0; z < 13; ++z)
    for (int64_t y = 0; y < 17; ++y)
      for (int64_t x = 0; x < 20; ++x)
      {
        const float v = values[static_cast<size_t>((x + 5) + kSide * ((y + 7) + kSide * (z + 9)))];
        same = same && read[static_cast<size_t>(x + 20 * (y + 17 * z))] == v;
        lo = std::min(lo, double(v));
        hi = std::max(hi, double(v));
      }
  EXPECT_TRUE(same && range.min == lo && range.max == hi && range.finite == box.samples());
  int64_t boxLo[3], boxHi[3];
  EXPECT_TRUE(box.readTally->box(boxLo, boxHi) && boxLo[0] == 5 && boxHi[0] == 24 && boxLo[1] == 7 &&
    boxHi[1] == 23 && boxLo[2] == 9 && boxHi[2] == 21 && box.readTally->bytes() == 2 * box.bytes());
  const int64_t inner[3] = { 1, 2, 3 }, one[3] = { 1, 1, 1 };
  const nv::VolumeFileLayout nested = nv::volumeFileSubBox(box, inner, one);
  float corner = 0.0f;
  nv::VolumeFileReader(nested).readBox({ 0, 0, 0 }, { 1, 1, 1 }, &corner);
  EXPECT_TRUE(corner == values[static_cast<size_t>(6 + kSide * (9 + kSide * 12))]);
  const int64_t outside[3] = { 1, 1, 1 };
  EXPECT_THROW_MSG(nv::volumeFileSubBox(box, size, outside), "inside");
  // A network of the whole field measured over boxes: x and z splits (rows and planes of the grid) add up.
  const nv::VolumeView view = nvtest::cubeView(values, kSide);
  nv::TrainConfig train = trainConfig();
  nvtest::SessionTrainer memory = nvtest::createTrainer(
    nv::Device::Cpu, nvtest::untrainedModel(nvtest::smallModelConfig(12), view, 5), view, train);
  for (int s = 0; s < 30; ++s)
    memory->step();
  memory->publish();
  nv::VolumeFileReader whole(layout);
  const nv::ErrorStats all = nv::measureOnFile(*memory.s, whole, view.valueMin, view.valueMax, 64 << 10);
  for (int axis : { 0, 2 })
  {
    int64_t aLo[3] = { 0, 0, 0 }, aHi[3] = { kSide - 1, kSide - 1, kSide - 1 };
    int64_t bLo[3] = { 0, 0, 0 }, bHi[3] = { kSide - 1, kSide - 1, kSide - 1 };
    aHi[axis] = 14;
    bLo[axis] = 15;
    const nv::ErrorStats a = nv::measureBoxOnFile(*memory.s, whole, aLo, aHi, view.valueMin, view.valueMax, 64 << 10);
    const nv::ErrorStats b = nv::measureBoxOnFile(*memory.s, whole, bLo, bHi, view.valueMin, view.valueMax, 64 << 10);
    std::printf("  axis %d: boxes %.4f / %.4f dB, whole %.4f dB\n", axis, a.psnr, b.psnr, all.psnr);
    EXPECT_TRUE(a.count + b.count == all.count && std::max(a.maxAbsError, b.maxAbsError) == all.maxAbsError);
    EXPECT_NEAR_REL((a.mse * double(a.count) + b.mse * double(b.count)) / double(all.count), all.mse, 1e-9, 0.0);
  }
}

int main(int argc, char** argv)
{
  return nvtest::runCasesInTempFolder(argc, argv);
}
