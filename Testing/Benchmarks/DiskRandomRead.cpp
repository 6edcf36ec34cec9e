// The disk's random-read bandwidth for the out-of-core block buffer's access pattern (issue 22's benchmark): random
// blocks of (edge + 1)^3 samples of a raw volume file, each read row by row with pread as VolumeFileReader reads a
// block, from `threads` threads, the file first dropped from the page cache. Prints one JSON line: useful MB/s (the
// bytes the blocks hold), blocks/s and reads/s.
//   nvDiskRandomRead RAW NX NY NZ ITEM_BYTES EDGE SECONDS THREADS
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
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
  if (argc != 9)
  {
    std::fprintf(stderr, "usage: %s RAW NX NY NZ ITEM_BYTES EDGE SECONDS THREADS\n", argv[0]);
    return 2;
  }
  const int64_t nx = std::atoll(argv[2]), ny = std::atoll(argv[3]), nz = std::atoll(argv[4]);
  const int64_t item = std::atoll(argv[5]), side = std::atoll(argv[6]) + 1;
  const double seconds = std::atof(argv[7]);
  const int threads = std::atoi(argv[8]);
  if (nx < side || ny < side || nz < side || item < 1 || side < 2 || threads < 1 || seconds <= 0)
  {
    std::fprintf(stderr, "invalid arguments\n");
    return 2;
  }
  const int fd = ::open(argv[1], O_RDONLY);
  if (fd < 0)
  {
    std::perror(argv[1]);
    return 1;
  }
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  std::atomic<int64_t> bytes{ 0 }, blocks{ 0 }, reads{ 0 };
  std::atomic<bool> failed{ false };
  const auto start = std::chrono::steady_clock::now();
  const auto deadline = start + std::chrono::duration<double>(seconds);
  auto reader = [&](unsigned seed) {
    std::mt19937_64 random(seed);
    std::vector<unsigned char> row(static_cast<size_t>(side * item));
    while (std::chrono::steady_clock::now() < deadline && !failed)
    {
      const int64_t x = int64_t(random() % uint64_t(nx - side + 1)), y = int64_t(random() % uint64_t(ny - side + 1)),
                    z = int64_t(random() % uint64_t(nz - side + 1));
      for (int64_t k = 0; k < side; ++k)
        for (int64_t j = 0; j < side; ++j)
        {
          const int64_t offset = (((z + k) * ny + y + j) * nx + x) * item;
          if (::pread(fd, row.data(), row.size(), static_cast<off_t>(offset)) != static_cast<ssize_t>(row.size()))
            failed = true;
          bytes += static_cast<int64_t>(row.size());
          ++reads;
        }
      ++blocks;
    }
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
  std::printf("{\"mb_per_s\": %.3f, \"blocks_per_s\": %.1f, \"reads_per_s\": %.1f, \"block_samples\": %lld, "
              "\"threads\": %d, \"seconds\": %.2f}\n",
    double(bytes) / elapsed / 1e6, double(blocks) / elapsed, double(reads) / elapsed,
    static_cast<long long>(side * side * side), threads, elapsed);
  return 0;
}
