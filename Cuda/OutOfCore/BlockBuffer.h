// NeuralVolume engine, out-of-core training (issue 22): the paper's random block buffer. A bounded number of blocks
// of a volume file (VolumeFileReader.h) are resident; training samples are drawn from them at random positions
// (trilinear, as the in-memory samplers interpolate the field); reader threads load replacement blocks with pread
// while training goes on, and advance() swaps the ready ones in. Memory: every slot, resident or loading, lies in
// one allocation within the byte budget given, its block's place and list entries beside it (36 bytes); nothing else grows with the
// file.
//
//   nv::BlockBuffer buffer(layout, { 256 << 20, 32, 4 });  // 256 MiB, 32^3-cell blocks, 4 reader threads
//   (config.blockCellsX = 64 with blockCells = 2: bricks of 64 x 2 x 2 cells; config.pageCache = Bypass: O_DIRECT)
//   buffer.drawSamples(65536, seed, step, xyz, values);     // xyz in [0,1]^3 of the volume, values in file units
//   buffer.advance(8);                                      // up to 8 blocks replaced by loaded ones (never waits)
#pragma once

#include "VolumeFileReader.h"

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace nv
{

struct BlockBufferConfig
{
  int64_t memoryBudgetBytes = int64_t(256) << 20; ///< every slot's samples (resident and loading)
  int blockCells = 32;    ///< cells per block edge; a block holds (blockCells + 1)^3 samples (its far faces shared)
  int readerThreads = 4;  ///< threads reading replacement blocks
  int loadingSlots = 0;   ///< slots the readers fill while the others are drawn from (0: automatic)
  uint64_t seed = 1;      ///< which blocks are read, in which order
  /// Cells along x (0: blockCells): bricks long in x (a block's rows are read whole, one pread each) hold more cells
  /// per read and per byte: 32 x 2 x 2 cells are 9 reads of 33 samples for 128 cells, 2^3 cells 9 reads of 3 for 8.
  int blockCellsX = 0;
  /// Whether the readers go through the page cache (VolumeFileReader.h, PageCacheUse): Bypass reads the disk itself
  /// (O_DIRECT), as on a machine whose memory cannot hold the file.
  PageCacheUse pageCache = PageCacheUse::Normal;
  /// Nice increment of each reader thread (Linux; 0: the caller's priority). Beside a GPU trainer, whose host sampling
  /// is a parallel-for over every core held up by any thread a reader preempts, 10: the readers take the cores
  /// training leaves idle. Beside the CPU engine, whose threads never leave a core idle, 0 (at 10 the readers starve).
  int readerNice = 0;
  /// Keep one bit per block of the volume: whether it was ever resident (BlockBufferStats::blocksEverResident; the
  /// bits grow with the file: for measurements).
  bool trackCoverage = false;
};

struct BlockBufferStats
{
  int64_t residentBlocks = 0;   ///< blocks samples are drawn from
  int64_t loadingSlots = 0;     ///< slots the readers fill meanwhile
  int64_t blocksRead = 0;       ///< blocks read since the start
  int64_t blocksSwapped = 0;    ///< replacements made by advance()
  int64_t swapsMissed = 0;      ///< replacements advance() asked for while no block was ready (reads too slow)
  int64_t bytesRead = 0;        ///< bytes read from the file
  int64_t bytesTransferred = 0; ///< bytes the reads took from the file (PageCacheUse::Bypass: whole 4 KiB pages)
  PageCacheUse pageCache = PageCacheUse::Normal; ///< in effect (Bypass where O_DIRECT is refused: DropBehind)
  int64_t bufferBytes = 0;      ///< bytes held by the slots
  int64_t blockCount = 0;       ///< blocks of the volume
  int64_t blocksEverResident = -1; ///< distinct blocks drawn from so far (-1: not tracked, trackCoverage off)
  int blockCells[3] = { 1, 1, 1 }; ///< cells per block along x, y, z
};

class BlockBuffer
{
public:
  /// Fills every resident slot before it returns (the first reads), then starts the readers. Throws nv::Error when
  /// the budget cannot hold two blocks or the file cannot be read.
  BlockBuffer(const VolumeFileLayout& layout, const BlockBufferConfig& config);
  ~BlockBuffer();
  BlockBuffer(const BlockBuffer&) = delete;
  BlockBuffer& operator=(const BlockBuffer&) = delete;

  /// `count` samples of step `step`: positions xyz (interleaved, [0,1]^3 of the whole volume) uniform inside the
  /// resident blocks, each block as likely as its share of their cells (a smaller block at the volume's far faces is
  /// drawn less often: the draws are uniform over the resident part of the volume), and the trilinearly
  /// interpolated values in the file's units. O(1) a sample, whatever the number of blocks. Not to be called while
  /// advance() runs (the training loop calls them in turn).
  /// `first`: the index of the first sample (draws are a function of seed, step and index: threads may fill disjoint
  /// ranges of one step).
  void drawSamples(int64_t count, uint64_t seed, uint64_t step, float* xyz, float* values, int64_t first = 0) const;
  /// Swaps up to `blocks` loaded blocks in for random resident ones (the replaced slots go back to the readers);
  /// never waits for a read. Rethrows a reader's error (the file shrank, an I/O error).
  void advance(int blocks);
  BlockBufferStats stats() const;
  /// The budget a slot of full blocks of `blockCells` cells per edge takes: its samples and its bookkeeping.
  static int64_t bytesPerSlot(int blockCells);
  static int64_t bytesPerSlot(int cellsX, int cellsY, int cellsZ);
  const VolumeFileLayout& layout() const { return Reader.layout(); }

private:
  struct Slot
  {
    int32_t origin[3] = { 0, 0, 0 }; ///< first sample of the block (a model's axes hold at most 2^20 samples)
    int16_t cells[3] = { 1, 1, 1 };  ///< cells it spans per axis (fewer at the volume's far faces; blockCells <= 1024)
    int32_t cellCount = 1;           ///< cells[0] * cells[1] * cells[2], flat axes counting 1
  };

  float* samplesOf(int64_t slot) { return this->Arena.data() + slot * this->SamplesPerSlot; }
  const float* samplesOf(int64_t slot) const { return this->Arena.data() + slot * this->SamplesPerSlot; }
  void load(int64_t slot, uint64_t blockIndex);
  /// Sets the slot's place to block `blockIndex`: origin and size (samples per axis) of the box it holds.
  void place(int64_t slot, uint64_t blockIndex, std::array<int64_t, 3>& origin, std::array<int64_t, 3>& size);
  /// The first reads: every resident slot, on every core (at most 16), in the file's order a pencil at a time.
  void fillResidents(int64_t resident, bool wholeVolume);
  /// The first reads of the slots order[begin, end), blocks of one pencil along x sorted by x: the rows of
  /// neighbouring blocks read at once (`rows` holds them), not a row of each block per call.
  void loadPencil(const std::vector<int64_t>& order, const std::vector<uint64_t>& blocks, int64_t begin, int64_t end,
    std::vector<float>& rows);
  /// The resident position of sample `index` of a step: uniform over the resident slots, a smaller block at the far
  /// faces kept with the probability of its share of a full block's cells (O(1), no table of weights).
  int64_t drawPosition(uint64_t seed, uint64_t step, uint64_t index) const;
  uint64_t randomBlock(uint64_t draw) const;
  void readerLoop();

  VolumeFileReader Reader;
  BlockBufferConfig Config;
  int64_t Edge[3] = { 1, 1, 1 };  ///< cells per block along each axis
  int64_t BlocksPerAxis[3] = { 1, 1, 1 };
  int64_t BlockCount = 1;
  int64_t SamplesPerSlot = 1;      ///< a full block's samples
  int32_t FullCellCount = 1;       ///< a full block's cells (flat axes counting 1)
  std::vector<float> Arena;        ///< every slot's samples, SamplesPerSlot apart: the budget, allocated once
  std::vector<Slot> Slots;         ///< resident first (Resident[k] indexes them), then loading
  std::vector<int32_t> Resident;   ///< slot of each resident block
  std::vector<int32_t> Free;       ///< slots waiting for a reader
  std::vector<int32_t> Ready;      ///< slots a reader filled, waiting for advance()
  mutable std::mutex Mutex;
  std::condition_variable Wake;
  std::vector<std::thread> Readers;
  bool Stopping = false;
  std::exception_ptr ReaderError;
  uint64_t NextDraw = 0;           ///< readers' block draws (under Mutex)
  uint64_t SwapDraw = 0;           ///< advance()'s choices of the block to replace
  std::atomic<int64_t> BlocksRead{ 0 };
  std::vector<uint8_t> EverResident; ///< trackCoverage: a bit per block
  int64_t EverResidentCount = 0;
  void markResident(int64_t slot);
  int64_t BlocksSwapped = 0, SwapsMissed = 0;
};

} // namespace nv
