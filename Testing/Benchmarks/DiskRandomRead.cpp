// The disk's random-read bandwidth for the out-of-core block buffer's access pattern (issue 22's benchmark): random
// blocks of (edge_x + 1) x (edge + 1)^2 samples of a raw volume file read by the engine's own nv::VolumeFileReader
// (the reads the buffer's readers make, to the byte: a row a read, or with direct a z-slice's rows a read where they
// lie within VolumeFileReader::kSliceSpanBytes), from `threads` threads. MODE cold (default): pread through the page
// cache, the file first dropped from it (the pages read stay cached: a long run reads the cache more and more);
// direct: O_DIRECT (PageCacheUse::Bypass: whole 4 KiB pages into aligned memory, as fio --direct=1; the disk itself,
// every read, on any machine, whatever its memory). Prints one JSON line: useful MB/s (the bytes the blocks hold),
// MB/s transferred (whole pages with direct), blocks/s and reads/s.
//   nvDiskRandomRead RAW NX NY NZ ITEM_BYTES EDGE SECONDS THREADS [EDGE_X [cold|direct]]
#include "OutOfCore/VolumeFileReader.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace
{
bool typeOfItem(int64_t item, nv::ScalarType& type)
{
  switch (item)
  {
    case 1: type = nv::ScalarType::UInt8; return true;
    case 2: type = nv::ScalarType::UInt16; return true;
    case 4: type = nv::ScalarType::Float32; return true;
    case 8: type = nv::ScalarType::Float64; return true;
    default: return false;
  }
}
} // namespace

int main(int argc, char** argv)
{
  if (argc < 9 || argc > 11)
  {
    std::fprintf(stderr, "usage: %s RAW NX NY NZ ITEM_BYTES EDGE SECONDS THREADS [EDGE_X [cold|direct]]\n", argv[0]);
    return 2;
  }
  nv::VolumeFileLayout layout;
  layout.headerPath = layout.dataPath = argv[1];
  for (int axis = 0; axis < 3; ++axis)
    layout.dims[axis] = std::atoll(argv[2 + axis]);
  const int64_t item = std::atoll(argv[5]), side = std::atoll(argv[6]) + 1;
  const double seconds = std::atof(argv[7]);
  const int threads = std::atoi(argv[8]);
  const int64_t sideX = argc > 9 && std::atoll(argv[9]) > 0 ? std::atoll(argv[9]) + 1 : side;
  const bool direct = argc > 10 && std::strcmp(argv[10], "direct") == 0;
  if (argc > 10 && !direct && std::strcmp(argv[10], "cold") != 0)
  {
    std::fprintf(stderr, "MODE is cold or direct\n");
    return 2;
  }
  const int64_t nx = layout.dims[0], ny = layout.dims[1], nz = layout.dims[2];
  if (!typeOfItem(item, layout.type) || nx < sideX || ny < side || nz < side || side < 2 || threads < 1 || seconds <= 0)
  {
    std::fprintf(stderr, "invalid arguments\n");
    return 2;
  }
  {
    const int fd = ::open(argv[1], O_RDONLY);
    if (fd < 0)
    {
      std::perror(argv[1]);
      return 1;
    }
    ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED); // cold: the file's cached pages dropped first
    ::close(fd);
  }
  try
  {
    nv::VolumeFileReader reader(layout, direct ? nv::PageCacheUse::Bypass : nv::PageCacheUse::Normal);
    if (direct && reader.pageCache() != nv::PageCacheUse::Bypass)
    {
      std::fprintf(stderr, "this file system refuses O_DIRECT\n");
      return 1;
    }
    std::atomic<int64_t> blocks{ 0 };
    std::atomic<bool> failed{ false };
    const auto start = std::chrono::steady_clock::now();
    const auto deadline = start + std::chrono::duration<double>(seconds);
    auto work = [&](unsigned seed) {
      std::mt19937_64 random(seed);
      std::vector<float> box(static_cast<size_t>(sideX * side * side));
      try
      {
        while (std::chrono::steady_clock::now() < deadline && !failed)
        {
          const int64_t x = int64_t(random() % uint64_t(nx - sideX + 1)),
                        y = int64_t(random() % uint64_t(ny - side + 1)), z = int64_t(random() % uint64_t(nz - side + 1));
          reader.readBox({ x, y, z }, { sideX, side, side }, box.data());
          ++blocks;
        }
      }
      catch (const std::exception& e)
      {
        std::fprintf(stderr, "%s\n", e.what());
        failed = true;
      }
    };
    std::vector<std::thread> workers;
    for (int t = 0; t < threads; ++t)
      workers.emplace_back(work, 1000u + unsigned(t));
    for (std::thread& worker : workers)
      worker.join();
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (failed)
      return 1;
    std::printf("{\"mb_per_s\": %.3f, \"transferred_mb_per_s\": %.3f, \"blocks_per_s\": %.1f, \"reads_per_s\": %.1f, "
                "\"block_samples\": %lld, \"threads\": %d, \"seconds\": %.2f, \"mode\": \"%s\"}\n",
      double(reader.bytesRead()) / elapsed / 1e6, double(reader.bytesTransferred()) / elapsed / 1e6,
      double(blocks) / elapsed, double(reader.readCalls()) / elapsed, static_cast<long long>(sideX * side * side),
      threads, elapsed, direct ? "direct" : "cold");
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
