// Out-of-core training's random block buffer (issue 22): samples drawn from the resident blocks sit where their
// values say (a linear field, which trilinear interpolation reproduces), the slots fit the memory budget, readers
// replace blocks while samples are drawn until the whole volume has been visited, a volume that fits is resident
// whole, and a file that shrinks under the readers is an error at the next advance(), never a crash. Reads that
// bypass the page cache (O_DIRECT, drop-behind) give the same values bit for bit, bricks long in x too.
//   nvTestBlockBuffer [case]
#include "Core/Error.h"
#include "OutOfCore/BlockBuffer.h"
#include "TempFolder.h"
#include "TestHarness.h"

#include <chrono>
#include <array>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <set>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

namespace
{
std::string tempDir()
{
  return nvtest::tempFolder();
}

double linear(double x, double y, double z)
{
  return 1.0 + 2.0 * x + 3.0 * y + 5.0 * z;
}

/// A float32 .nhdr volume of the linear field; its layout.
nv::VolumeFileLayout linearVolume(const std::string& name, int64_t nx, int64_t ny, int64_t nz)
{
  const std::string raw = tempDir() + "/" + name + ".raw";
  std::ofstream data(raw, std::ios::binary);
  for (int64_t z = 0; z < nz; ++z)
    for (int64_t y = 0; y < ny; ++y)
      for (int64_t x = 0; x < nx; ++x)
      {
        const float v = static_cast<float>(linear(double(x), double(y), double(z)));
        data.write(reinterpret_cast<const char*>(&v), sizeof(v));
      }
  data.close();
  std::ofstream header(tempDir() + "/" + name + ".nhdr");
  header << "NRRD0004\ntype: float\ndimension: 3\nsizes: " << nx << " " << ny << " " << nz
         << "\nencoding: raw\nendian: little\ndata file: " << name << ".raw\n";
  header.close();
  return nv::readVolumeFileLayout(tempDir() + "/" + name + ".nhdr");
}

/// Samples whose value is not the linear field at their position (in samples: xyz * (dims - 1)).
int64_t misplaced(const nv::VolumeFileLayout& layout, const std::vector<float>& xyz, const std::vector<float>& values)
{
  int64_t wrong = 0;
  for (size_t i = 0; i < values.size(); ++i)
  {
    double p[3];
    for (int axis = 0; axis < 3; ++axis)
      p[axis] = layout.dims[axis] == 1 ? 0.0 : xyz[3 * i + axis] * double(layout.dims[axis] - 1);
    const double expected = linear(p[0], p[1], p[2]);
    wrong += !(std::fabs(values[i] - expected) <= 1e-3 * (1.0 + std::fabs(expected)));
  }
  return wrong;
}
} // namespace

NV_TEST(samples_sit_where_their_values_say)
{
  const nv::VolumeFileLayout layout = linearVolume("lin", 37, 21, 17);
  nv::BlockBufferConfig config;
  config.blockCells = 8;
  // 12 slots of 9^3 samples and their bookkeeping (place, list entries: under 64 bytes): 9 resident, 3 loading
  config.memoryBudgetBytes = 12 * (9 * 9 * 9 * 4 + 64);
  nv::BlockBuffer buffer(layout, config);
  const nv::BlockBufferStats s = buffer.stats();
  EXPECT_TRUE(s.residentBlocks == 9 && s.loadingSlots == 3);
  EXPECT_TRUE(s.bufferBytes <= config.memoryBudgetBytes);
  // Loading slots asked for: as many, within the same slots (at least one stays resident).
  nv::BlockBufferConfig asked = config;
  asked.loadingSlots = 5;
  EXPECT_TRUE(nv::BlockBuffer(layout, asked).stats().loadingSlots == 5);
  asked.loadingSlots = 40;
  const nv::BlockBufferStats most = nv::BlockBuffer(layout, asked).stats();
  EXPECT_TRUE(most.residentBlocks == 1 && most.loadingSlots == 11 && most.bufferBytes <= config.memoryBudgetBytes);
  std::vector<float> xyz(3 * 20000), values(20000);
  for (uint64_t step = 0; step < 20; ++step)
  {
    buffer.drawSamples(20000, 7, step, xyz.data(), values.data());
    EXPECT_NEAR_REL(double(misplaced(layout, xyz, values)), 0.0, 0.0, 0.0);
    buffer.advance(2);
  }
  // Resident whole (5 x 3 x 2 blocks, the far ones smaller: 4 of 36 cells in x, 4 of 20 in y, none in z): the draws
  // are uniform over the volume, the smaller blocks drawn as often as their share of the cells.
  nv::BlockBufferConfig whole = config;
  whole.memoryBudgetBytes = 64 * (9 * 9 * 9 * 4 + 56);
  nv::BlockBuffer wholeBuffer(layout, whole);
  EXPECT_TRUE(wholeBuffer.stats().residentBlocks == 30 && wholeBuffer.stats().loadingSlots == 0);
  const int64_t draws = 200000;
  std::vector<float> many(3 * draws), manyValues(draws);
  wholeBuffer.drawSamples(draws, 11, 0, many.data(), manyValues.data());
  int64_t farX = 0, farY = 0;
  for (int64_t i = 0; i < draws; ++i)
  {
    farX += many[3 * i] > 32.0f / 36.0f ? 1 : 0;
    farY += many[3 * i + 1] > 16.0f / 20.0f ? 1 : 0;
  }
  std::printf("  far blocks drawn: x %.4f (expected %.4f), y %.4f (expected %.4f)\n", double(farX) / draws, 4.0 / 36.0,
    double(farY) / draws, 4.0 / 20.0);
  EXPECT_NEAR_REL(double(farX) / draws, 4.0 / 36.0, 0.0, 0.03);
  EXPECT_NEAR_REL(double(farY) / draws, 4.0 / 20.0, 0.0, 0.03);
  // A flat volume (one sample along z): z at the middle, the values those of the plane.
  const nv::VolumeFileLayout flat = linearVolume("flat", 9, 7, 1);
  nv::BlockBuffer flatBuffer(flat, config);
  flatBuffer.drawSamples(1000, 3, 0, xyz.data(), values.data());
  values.resize(1000);
  xyz.resize(3000);
  EXPECT_TRUE(xyz[2] == 0.5f && xyz[2997 + 2] == 0.5f);
  EXPECT_NEAR_REL(double(misplaced(flat, xyz, values)), 0.0, 0.0, 0.0);
}

NV_TEST(the_first_fill_reads_pencils_and_places_every_block)
{
  // 18 x 10 x 8 blocks of 4 cells (the far ones 1 cell in x and y, 2 in z); about 400 of them resident, drawn at
  // random (some twice): the first fill reads each pencil of blocks along x a row at a time, on several threads.
  const nv::VolumeFileLayout layout = linearVolume("pencils", 70, 38, 31);
  nv::BlockBufferConfig config;
  config.blockCells = 4;
  config.loadingSlots = 8;
  config.memoryBudgetBytes = 408 * nv::BlockBuffer::bytesPerSlot(4) + 64; // 400 resident, 8 loading
  nv::BlockBuffer buffer(layout, config);
  const nv::BlockBufferStats s = buffer.stats();
  std::printf("  %lld resident blocks, %lld read, %lld bytes read\n", (long long)s.residentBlocks,
    (long long)s.blocksRead, (long long)s.bytesRead);
  // The readers may have filled their 8 slots already.
  EXPECT_TRUE(s.residentBlocks == 400 && s.blocksRead >= 400 && s.blocksRead <= 408);
  // At most the rows of every pencil once (80 pencils of 5 x 5 rows of 70 samples) and the readers' 8 blocks.
  EXPECT_TRUE(s.bytesRead <= 80 * 5 * 5 * 70 * 4 + 8 * 5 * 5 * 5 * 4);
  const int64_t draws = 200000;
  std::vector<float> xyz(3 * draws), values(draws);
  buffer.drawSamples(draws, 13, 0, xyz.data(), values.data());
  EXPECT_NEAR_REL(double(misplaced(layout, xyz, values)), 0.0, 0.0, 0.0);
}

NV_TEST(readers_visit_the_whole_volume_within_the_budget)
{
  const nv::VolumeFileLayout layout = linearVolume("visit", 65, 49, 33); // 8 x 6 x 4 blocks of 8 cells
  nv::BlockBufferConfig config;
  config.blockCells = 8;
  config.readerThreads = 2;
  config.memoryBudgetBytes = 20 * 9 * 9 * 9 * 4;
  nv::BlockBuffer buffer(layout, config);
  std::set<int64_t> visited;
  std::vector<float> xyz(3 * 4096), values(4096);
  const auto start = std::chrono::steady_clock::now();
  for (uint64_t step = 0; visited.size() < 192 && std::chrono::steady_clock::now() - start < std::chrono::seconds(60);
       ++step)
  {
    buffer.drawSamples(4096, 11, step, xyz.data(), values.data());
    for (int i = 0; i < 4096; ++i)
    {
      int64_t block[3];
      for (int axis = 0; axis < 3; ++axis)
        block[axis] = std::min<int64_t>(static_cast<int64_t>(xyz[3 * i + axis] * double(layout.dims[axis] - 1)) / 8,
          (layout.dims[axis] - 2) / 8);
      visited.insert((block[2] * 6 + block[1]) * 8 + block[0]);
    }
    buffer.advance(3);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const nv::BlockBufferStats s = buffer.stats();
  std::printf("  %zu of 192 blocks visited, %lld read, %lld swapped, %lld swaps missed, %lld bytes read, buffer %lld "
              "bytes\n", visited.size(), (long long)s.blocksRead, (long long)s.blocksSwapped,
    (long long)s.swapsMissed, (long long)s.bytesRead, (long long)s.bufferBytes);
  EXPECT_TRUE(visited.size() == 192);
  EXPECT_TRUE(s.blocksSwapped > 0 && s.bufferBytes <= config.memoryBudgetBytes);
  EXPECT_TRUE(s.bytesRead >= s.blocksRead * 9 * 9 * 4); // at least a row of every block read
  config.memoryBudgetBytes = 9 * 9 * 9 * 4; // one block
  EXPECT_THROW_MSG(nv::BlockBuffer(layout, config), "holds fewer than two blocks");
}

NV_TEST(a_volume_that_fits_is_resident_whole_and_repeatable)
{
  const nv::VolumeFileLayout layout = linearVolume("fits", 17, 17, 9); // 2 x 2 x 1 blocks of 8 cells
  nv::BlockBufferConfig config;
  config.blockCells = 8;
  config.memoryBudgetBytes = int64_t(1) << 20;
  nv::BlockBuffer first(layout, config), second(layout, config);
  EXPECT_TRUE(first.stats().residentBlocks == 4 && first.stats().loadingSlots == 0);
  std::vector<float> xyz1(3 * 5000), v1(5000), xyz2(3 * 5000), v2(5000);
  first.drawSamples(5000, 5, 1, xyz1.data(), v1.data());
  first.advance(10); // nothing to replace
  second.drawSamples(5000, 5, 1, xyz2.data(), v2.data());
  EXPECT_TRUE(xyz1 == xyz2 && v1 == v2);
  EXPECT_TRUE(first.stats().blocksSwapped == 0 && first.stats().blocksRead == 4);
}

NV_TEST(a_file_that_shrinks_under_the_readers_is_an_error)
{
  const nv::VolumeFileLayout layout = linearVolume("shrinks", 65, 65, 65);
  nv::BlockBufferConfig config;
  config.blockCells = 8;
  config.memoryBudgetBytes = 16 * 9 * 9 * 9 * 4;
  nv::BlockBuffer buffer(layout, config);
  EXPECT_TRUE(truncate(layout.dataPath.c_str(), 4096) == 0);
  std::string message;
  const auto start = std::chrono::steady_clock::now();
  while (message.empty() && std::chrono::steady_clock::now() - start < std::chrono::seconds(10))
  {
    try
    {
      buffer.advance(4);
    }
    catch (const nv::Error& e)
    {
      message = e.what();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(message.find("it shrank") != std::string::npos);
}

namespace
{
/// A big-endian uint16 .nrrd (header before the samples: no sample starts on a page) of pseudo-random values,
/// 131 x 37 x 29: rows not page-aligned, the file's last page partial.
nv::VolumeFileLayout scrambledNrrd(const std::string& name)
{
  const int64_t nx = 131, ny = 37, nz = 29;
  std::ofstream file(tempDir() + "/" + name + ".nrrd", std::ios::binary);
  file << "NRRD0004\ntype: uint16\ndimension: 3\nsizes: " << nx << " " << ny << " " << nz
       << "\nencoding: raw\nendian: big\n\n";
  uint64_t state = 12345;
  for (int64_t k = 0; k < nx * ny * nz; ++k)
  {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const unsigned char bytes[2] = { static_cast<unsigned char>(state >> 56), static_cast<unsigned char>(state >> 48) };
    file.write(reinterpret_cast<const char*>(bytes), 2);
  }
  file.close();
  return nv::readVolumeFileLayout(tempDir() + "/" + name + ".nrrd");
}
} // namespace

NV_TEST(reads_that_bypass_the_page_cache_give_the_same_bits)
{
  const nv::VolumeFileLayout layout = scrambledNrrd("bypass");
  EXPECT_TRUE(layout.dataOffset % 4096 != 0 && layout.bytes() % 4096 != 0);
  nv::VolumeFileReader normal(layout), direct(layout, nv::PageCacheUse::Bypass),
    dropBehind(layout, nv::PageCacheUse::DropBehind);
  std::printf("  page-cache use in effect: Bypass asked -> %d (1: O_DIRECT, 2: drop behind), DropBehind -> %d\n",
    int(direct.pageCache()), int(dropBehind.pageCache()));
  EXPECT_TRUE(dropBehind.pageCache() == nv::PageCacheUse::DropBehind && direct.pageCache() != nv::PageCacheUse::Normal);
  // Boxes at random places and sizes, the file's last sample and the whole volume among them.
  std::vector<std::array<int64_t, 6>> boxes = { { 0, 0, 0, 131, 37, 29 }, { 130, 36, 28, 1, 1, 1 },
    { 0, 36, 28, 131, 1, 1 }, { 5, 3, 2, 33, 3, 3 } };
  uint64_t state = 99;
  auto next = [&state](int64_t n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<int64_t>((state >> 33) % uint64_t(n));
  };
  for (int k = 0; k < 200; ++k)
  {
    std::array<int64_t, 6> box{};
    for (int axis = 0; axis < 3; ++axis)
    {
      box[axis] = next(layout.dims[axis]);
      box[3 + axis] = 1 + next(layout.dims[axis] - box[axis]);
    }
    boxes.push_back(box);
  }
  // The values written (scrambledNrrd's sequence, big-endian uint16): normal and O_DIRECT read a z-slice's close rows
  // in one read, drop-behind a row at a time; all three must give them.
  std::vector<float> written(static_cast<size_t>(layout.samples()));
  uint64_t sequence = 12345;
  for (float& value : written)
  {
    sequence = sequence * 6364136223846793005ull + 1442695040888963407ull;
    value = static_cast<float>(((sequence >> 56) << 8) | ((sequence >> 48) & 0xFF));
  }
  int64_t differing = 0, wrong = 0;
  for (const auto& box : boxes)
  {
    const std::array<int64_t, 3> origin{ box[0], box[1], box[2] }, size{ box[3], box[4], box[5] };
    const size_t count = static_cast<size_t>(size[0] * size[1] * size[2]);
    std::vector<float> a(count), b(count, -1.0f), c(count, -2.0f);
    normal.readBox(origin, size, a.data());
    direct.readBox(origin, size, b.data());
    dropBehind.readBox(origin, size, c.data());
    differing += std::memcmp(a.data(), b.data(), count * sizeof(float)) != 0;
    differing += std::memcmp(a.data(), c.data(), count * sizeof(float)) != 0;
    for (int64_t z = 0, k = 0; z < size[2]; ++z)
      for (int64_t y = 0; y < size[1]; ++y)
        for (int64_t x = 0; x < size[0]; ++x, ++k)
          wrong += a[size_t(k)] !=
            written[size_t(((origin[2] + z) * layout.dims[1] + origin[1] + y) * layout.dims[0] + origin[0] + x)];
  }
  EXPECT_TRUE(differing == 0 && wrong == 0);
  // A 64 x 2 x 2-cell brick of close rows: 3 reads through the cache and with O_DIRECT, 9 with drop-behind.
  const int64_t callsBefore[3] = { normal.readCalls(), direct.readCalls(), dropBehind.readCalls() };
  std::vector<float> brick(65 * 3 * 3);
  normal.readBox({ 10, 5, 7 }, { 65, 3, 3 }, brick.data());
  direct.readBox({ 10, 5, 7 }, { 65, 3, 3 }, brick.data());
  dropBehind.readBox({ 10, 5, 7 }, { 65, 3, 3 }, brick.data());
  EXPECT_TRUE(normal.readCalls() - callsBefore[0] == 3 && dropBehind.readCalls() - callsBefore[2] == 9);
  EXPECT_TRUE(direct.readCalls() - callsBefore[1] == (direct.pageCache() == nv::PageCacheUse::Bypass ? 3 : 9));
  EXPECT_TRUE(direct.bytesRead() == normal.bytesRead() && dropBehind.bytesRead() == normal.bytesRead());
  // O_DIRECT takes whole pages: at least the bytes asked.
  EXPECT_TRUE(direct.bytesTransferred() >= direct.bytesRead());
}

NV_TEST(a_buffer_that_bypasses_the_page_cache_draws_the_same_samples)
{
  // The same seed through the page cache and around it, cubes and bricks long in x: the same blocks, the same bits.
  const nv::VolumeFileLayout layout = linearVolume("bypassbuffer", 67, 41, 29);
  for (int brickX : { 0, 16 })
  {
    nv::BlockBufferConfig config;
    config.blockCells = 4;
    config.blockCellsX = brickX;
    config.memoryBudgetBytes = 40 * nv::BlockBuffer::bytesPerSlot(brickX > 0 ? brickX : 4, 4, 4);
    config.readerThreads = 1;
    nv::BlockBufferConfig around = config;
    around.pageCache = nv::PageCacheUse::Bypass;
    nv::BlockBuffer cached(layout, config), direct(layout, around);
    EXPECT_TRUE(direct.stats().pageCache != nv::PageCacheUse::Normal);
    EXPECT_TRUE(cached.stats().blockCells[0] == (brickX > 0 ? brickX : 4) && cached.stats().blockCells[1] == 4);
    std::vector<float> xyz1(3 * 4096), v1(4096), xyz2(3 * 4096), v2(4096);
    cached.drawSamples(4096, 7, 1, xyz1.data(), v1.data());
    direct.drawSamples(4096, 7, 1, xyz2.data(), v2.data());
    EXPECT_TRUE(std::memcmp(v1.data(), v2.data(), v1.size() * sizeof(float)) == 0 && xyz1 == xyz2);
    EXPECT_TRUE(misplaced(layout, xyz2, v2) == 0);
  }
}

int main(int argc, char** argv)
{
  return nvtest::runCasesInTempFolder(argc, argv);
}
