// The disk's random-read bandwidth for the out-of-core block buffer's access pattern (issue 22's benchmark): random
// blocks of (edge_x + 1) x (edge + 1)^2 samples of a raw volume file, each read row by row as VolumeFileReader reads
// a block, from `threads` threads. MODE cold (default): pread, the file first dropped from the page cache (the pages
// read stay cached: a long run reads the cache more and more); direct: O_DIRECT, each row widened to whole 4 KiB pages
// into aligned memory, as fio --direct=1 and the reader's PageCacheUse::Bypass read (the disk itself, every read, on
// any machine, whatever its memory). Prints one JSON line: useful MB/s (the bytes the blocks hold), MB/s transferred
// (whole pages with direct), blocks/s and reads/s.
//   nvDiskRandomRead RAW NX NY NZ ITEM_BYTES EDGE SECONDS THREADS [EDGE_X [cold|direct]]
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <thread>
#include <vector>

int main(int argc, char** argv)
{
  if (argc < 9 || argc > 11)
  {
    std::fprintf(stderr, "usage: %s RAW NX NY NZ ITEM_BYTES EDGE SECONDS THREADS [EDGE_X [cold|direct]]\n", argv[0]);
    return 2;
  }
  const int64_t nx = std::atoll(argv[2]), ny = std::atoll(argv[3]), nz = std::atoll(argv[4]);
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
  if (nx < sideX || ny < side || nz < side || item < 1 || side < 2 || threads < 1 || seconds <= 0)
  {
    std::fprintf(stderr, "invalid arguments\n");
    return 2;
  }
  const int fd = ::open(argv[1], O_RDONLY | (direct ? O_DIRECT : 0));
  if (fd < 0)
  {
    std::perror(argv[1]);
    return 1;
  }
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_RANDOM);
  constexpr int64_t kPage = 4096;
  std::atomic<int64_t> bytes{ 0 }, transferred{ 0 }, blocks{ 0 }, reads{ 0 };
  std::atomic<bool> failed{ false };
  const auto start = std::chrono::steady_clock::now();
  const auto deadline = start + std::chrono::duration<double>(seconds);
  auto reader = [&](unsigned seed) {
    std::mt19937_64 random(seed);
    const int64_t rowBytes = sideX * item;
    const size_t capacity = static_cast<size_t>((rowBytes + 2 * kPage) / kPage * kPage);
    unsigned char* row = static_cast<unsigned char*>(std::aligned_alloc(kPage, capacity));
    while (row && std::chrono::steady_clock::now() < deadline && !failed)
    {
      const int64_t x = int64_t(random() % uint64_t(nx - sideX + 1)), y = int64_t(random() % uint64_t(ny - side + 1)),
                    z = int64_t(random() % uint64_t(nz - side + 1));
      for (int64_t k = 0; k < side; ++k)
        for (int64_t j = 0; j < side; ++j)
        {
          const int64_t offset = (((z + k) * ny + y + j) * nx + x) * item;
          // direct: the whole pages around the row (O_DIRECT reads pages into aligned memory)
          const int64_t first = direct ? offset / kPage * kPage : offset;
          const int64_t span = direct ? (offset + rowBytes + kPage - 1) / kPage * kPage - first : rowBytes;
          const ssize_t got = ::pread(fd, row, static_cast<size_t>(span), static_cast<off_t>(first));
          if (got < offset + rowBytes - first)
            failed = true;
          bytes += rowBytes;
          transferred += got > 0 ? got : 0;
          ++reads;
        }
      ++blocks;
    }
    std::free(row);
  };
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t)
    workers.emplace_back(reader, 1000u + unsigned(t));
  for (std::thread& worker : workers)
    worker.join();
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ::close(fd);
  if (failed)
  {
    std::fprintf(stderr, "a read failed (is the file as large as NX*NY*NZ*ITEM_BYTES?)\n");
    return 1;
  }
  std::printf("{\"mb_per_s\": %.3f, \"transferred_mb_per_s\": %.3f, \"blocks_per_s\": %.1f, \"reads_per_s\": %.1f, "
              "\"block_samples\": %lld, \"threads\": %d, \"seconds\": %.2f, \"mode\": \"%s\"}\n",
    double(bytes) / elapsed / 1e6, double(transferred) / elapsed / 1e6, double(blocks) / elapsed,
    double(reads) / elapsed, static_cast<long long>(sideX * side * side), threads, elapsed, direct ? "direct" : "cold");
  return 0;
}
