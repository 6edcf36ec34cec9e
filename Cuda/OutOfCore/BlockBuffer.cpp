// NeuralVolume engine, out-of-core training: the random block buffer (BlockBuffer.h).
#include "BlockBuffer.h"

#include "Core/Error.h"
#include "Core/HashGridMath.h"
#include "Core/TrainingPoints.h"

#include <algorithm>
#include <array>
#include <climits>
#include <system_error>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace nv
{
namespace
{
/// Cells of the volume along an axis of `samples` samples (a flat axis has none).
int64_t cellsAlong(int64_t samples)
{
  return std::max<int64_t>(0, samples - 1);
}

/// Uniform in [0, 1) from a 64-bit hash (24 bits: exactly representable as a float).
float unitFloat(uint64_t hash)
{
  return static_cast<float>(hash >> 40) * (1.0f / 16777216.0f);
}
} // namespace

BlockBuffer::BlockBuffer(const VolumeFileLayout& layout, const BlockBufferConfig& config)
  : Reader(layout, config.pageCache)
  , Config(config)
{
  NV_CHECK(config.blockCells >= 1 && config.blockCells <= 1024, "blockCells must be 1..1024");
  NV_CHECK(config.blockCellsX >= 0 && config.blockCellsX <= 1024, "blockCellsX must be 0..1024");
  for (int axis = 0; axis < 3; ++axis)
    NV_CHECK(layout.dims[axis] >= 1 && layout.dims[axis] <= INT32_MAX, "a volume file's axis holds 1 to 2^31 samples");
  this->Edge[0] = config.blockCellsX > 0 ? config.blockCellsX : config.blockCells;
  this->Edge[1] = this->Edge[2] = config.blockCells;
  for (int axis = 0; axis < 3; ++axis)
  {
    const int64_t edge = this->Edge[axis];
    const int64_t cells = cellsAlong(layout.dims[axis]);
    this->BlocksPerAxis[axis] = cells == 0 ? 1 : (cells + edge - 1) / edge;
    this->SamplesPerSlot *= std::min(cells, edge) + 1;
    this->FullCellCount *= static_cast<int32_t>(std::max<int64_t>(1, std::min(cells, edge)));
  }
  this->BlockCount = this->BlocksPerAxis[0] * this->BlocksPerAxis[1] * this->BlocksPerAxis[2];
  if (config.trackCoverage)
    this->EverResident.assign(static_cast<size_t>((this->BlockCount + 7) / 8), 0);
  // A slot: its samples in the arena, its place (Slot) and its entry in Resident; a loading slot also has entries in
  // Free and Ready (8 bytes more).
  const int64_t slotBytes = this->SamplesPerSlot * static_cast<int64_t>(sizeof(float)) +
    static_cast<int64_t>(sizeof(Slot) + sizeof(int32_t));
  const int64_t slots = std::min<int64_t>(config.memoryBudgetBytes / slotBytes, INT32_MAX / 2);
  if (slots < 2)
    NV_THROW("the out-of-core memory budget (" + std::to_string(config.memoryBudgetBytes) + " bytes) holds fewer than "
      "two blocks of " + std::to_string(slotBytes) + " bytes: raise MemoryBudget or lower the block size");
  // The loading slots asked for, else a quarter of the slots (at most four per reader), are loading while the rest
  // are drawn from (less the slots their list entries take); a volume whose blocks all fit is resident whole and
  // nothing is replaced.
  int64_t loading = config.loadingSlots > 0
    ? std::min<int64_t>(config.loadingSlots, slots - 1)
    : std::max<int64_t>(1, std::min<int64_t>(slots / 4, 4 * std::max(1, config.readerThreads)));
  const int64_t loadingBytes = loading * (slotBytes + 2 * static_cast<int64_t>(sizeof(int32_t)));
  int64_t resident = std::max<int64_t>(1, std::min(slots - loading, (config.memoryBudgetBytes - loadingBytes) / slotBytes));
  if (resident >= this->BlockCount)
  {
    resident = this->BlockCount;
    loading = 0;
  }
  this->Arena.resize(static_cast<size_t>((resident + loading) * this->SamplesPerSlot)); // all the memory, up front
  this->Slots.resize(static_cast<size_t>(resident + loading));
  this->Resident.reserve(static_cast<size_t>(resident));
  this->Free.reserve(static_cast<size_t>(loading));
  this->Ready.reserve(static_cast<size_t>(loading));
  this->fillResidents(resident, loading == 0);
  for (int64_t k = resident; k < resident + loading; ++k)
    this->Free.push_back(static_cast<int32_t>(k));
  for (int t = 0; loading > 0 && t < std::max(1, config.readerThreads); ++t)
  {
    try
    {
      this->Readers.emplace_back([this]() { this->readerLoop(); });
    }
    catch (const std::system_error&)
    {
      break; // the threads the system gives; none: advance() reads in the caller's thread
    }
  }
}

void BlockBuffer::fillResidents(int64_t resident, bool wholeVolume)
{
  std::vector<uint64_t> blocks(static_cast<size_t>(resident));
  for (int64_t k = 0; k < resident; ++k)
    blocks[static_cast<size_t>(k)] = wholeVolume ? static_cast<uint64_t>(k) : this->randomBlock(this->NextDraw++);
  // The slots in the file's order of their blocks, cut into pencils (the blocks of one row of blocks along x): the
  // random blocks of a large buffer touch most pages of the file, and reading them a block row (32 bytes of 8^3-cell
  // float32 blocks) at a time made the first fill random 4 KiB reads over the whole file.
  std::vector<int64_t> order(static_cast<size_t>(resident));
  for (int64_t k = 0; k < resident; ++k)
    order[static_cast<size_t>(k)] = k;
  std::stable_sort(order.begin(), order.end(),
    [&blocks](int64_t a, int64_t b) { return blocks[static_cast<size_t>(a)] < blocks[static_cast<size_t>(b)]; });
  std::vector<int64_t> pencils; // where each pencil begins in `order`, then its end
  const uint64_t perPencil = static_cast<uint64_t>(this->BlocksPerAxis[0]);
  for (int64_t i = 0; i < resident; ++i)
    if (i == 0 || blocks[static_cast<size_t>(order[static_cast<size_t>(i)])] / perPencil !=
        blocks[static_cast<size_t>(order[static_cast<size_t>(i - 1)])] / perPencil)
      pencils.push_back(i);
  pencils.push_back(resident);
  const int64_t pencilCount = static_cast<int64_t>(pencils.size()) - 1;
  std::atomic<int64_t> next{ 0 };
  std::exception_ptr failure;
  std::mutex failureMutex;
  auto work = [&]() {
    std::vector<float> rows;
    try
    {
      for (int64_t p = next++; p < pencilCount; p = next++)
        this->loadPencil(order, blocks, pencils[static_cast<size_t>(p)], pencils[static_cast<size_t>(p + 1)], rows);
    }
    catch (...)
    {
      std::lock_guard<std::mutex> lock(failureMutex);
      failure = std::current_exception();
      next = pencilCount;
    }
  };
  std::vector<std::thread> threads;
  // The first reads are all there is to do: as many threads as the machine has (at least the readers, at most 16).
  const int threadCount = std::min(16, std::max(std::max(1, this->Config.readerThreads),
    static_cast<int>(std::thread::hardware_concurrency())));
  for (int t = 1; t < threadCount && pencilCount > 1 && resident > 64; ++t)
  {
    try
    {
      threads.emplace_back(work);
    }
    catch (const std::system_error&)
    {
      break;
    }
  }
  work();
  for (std::thread& thread : threads)
    thread.join();
  if (failure)
    std::rethrow_exception(failure);
  for (int64_t k = 0; k < resident; ++k)
  {
    this->Resident.push_back(static_cast<int32_t>(k));
    this->markResident(k);
  }
}

void BlockBuffer::markResident(int64_t slotIndex)
{
  if (this->EverResident.empty())
    return;
  const Slot& slot = this->Slots[static_cast<size_t>(slotIndex)];
  const int64_t block = slot.origin[0] / this->Edge[0] +
    this->BlocksPerAxis[0] * (slot.origin[1] / this->Edge[1] + this->BlocksPerAxis[1] * (slot.origin[2] / this->Edge[2]));
  uint8_t& bits = this->EverResident[static_cast<size_t>(block / 8)];
  const uint8_t bit = static_cast<uint8_t>(1u << (block % 8));
  this->EverResidentCount += (bits & bit) ? 0 : 1;
  bits |= bit;
}

void BlockBuffer::loadPencil(const std::vector<int64_t>& order, const std::vector<uint64_t>& blocks, int64_t begin,
  int64_t end, std::vector<float>& rows)
{
  if (this->Reader.layout().boxSource)
  {
    // A chunked source decodes whole chunks per call: a block per call, as the readers load them.
    for (int64_t i = begin; i < end; ++i)
      this->load(order[static_cast<size_t>(i)], blocks[static_cast<size_t>(order[static_cast<size_t>(i)])]);
    return;
  }
  // Neighbouring blocks whose gap is at most a page of the file share one read a row; a run's rows hold at most
  // kRunSamples samples (or one block's).
  constexpr int64_t kGapBytes = 4096, kRunSamples = int64_t(1) << 18;
  const int64_t item = static_cast<int64_t>(scalarSize(this->Reader.layout().type));
  std::vector<std::array<int64_t, 3>> origins(static_cast<size_t>(end - begin)), sizes(origins.size());
  for (int64_t i = begin; i < end; ++i)
  {
    const int64_t slot = order[static_cast<size_t>(i)];
    this->place(slot, blocks[static_cast<size_t>(slot)], origins[size_t(i - begin)], sizes[size_t(i - begin)]);
  }
  for (int64_t first = 0, count = end - begin; first < count;)
  {
    const std::array<int64_t, 3>& start = origins[size_t(first)];
    const int64_t ny = sizes[size_t(first)][1], nz = sizes[size_t(first)][2];
    int64_t last = first, x1 = start[0] + sizes[size_t(first)][0];
    while (last + 1 < count && (origins[size_t(last + 1)][0] - x1) * item <= kGapBytes &&
      (origins[size_t(last + 1)][0] + sizes[size_t(last + 1)][0] - start[0]) * ny <= kRunSamples)
    {
      ++last;
      x1 = std::max(x1, origins[size_t(last)][0] + sizes[size_t(last)][0]);
    }
    const int64_t span = x1 - start[0];
    rows.resize(static_cast<size_t>(span * ny));
    for (int64_t z = 0; z < nz; ++z)
    {
      this->Reader.readBox({ start[0], start[1], start[2] + z }, { span, ny, 1 }, rows.data());
      for (int64_t k = first; k <= last; ++k)
      {
        const int64_t nx = sizes[size_t(k)][0];
        float* into = this->samplesOf(order[static_cast<size_t>(begin + k)]) + z * ny * nx;
        for (int64_t y = 0; y < ny; ++y)
          std::copy_n(rows.data() + y * span + (origins[size_t(k)][0] - start[0]), nx, into + y * nx);
      }
    }
    this->BlocksRead += last - first + 1;
    first = last + 1;
  }
}
BlockBuffer::~BlockBuffer()
{
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->Stopping = true;
  }
  this->Wake.notify_all();
  for (std::thread& reader : this->Readers)
    reader.join();
}

uint64_t BlockBuffer::randomBlock(uint64_t draw) const
{
  return static_cast<uint64_t>(randomBankIndex(this->Config.seed, 0xB10C, draw, this->BlockCount));
}

void BlockBuffer::place(int64_t slotIndex, uint64_t blockIndex, std::array<int64_t, 3>& origin,
  std::array<int64_t, 3>& size)
{
  const VolumeFileLayout& layout = this->Reader.layout();
  Slot& slot = this->Slots[static_cast<size_t>(slotIndex)];
  int64_t block[3];
  block[0] = static_cast<int64_t>(blockIndex) % this->BlocksPerAxis[0];
  block[1] = static_cast<int64_t>(blockIndex) / this->BlocksPerAxis[0] % this->BlocksPerAxis[1];
  block[2] = static_cast<int64_t>(blockIndex) / (this->BlocksPerAxis[0] * this->BlocksPerAxis[1]);
  slot.cellCount = 1;
  for (int axis = 0; axis < 3; ++axis)
  {
    origin[axis] = block[axis] * this->Edge[axis];
    slot.origin[axis] = static_cast<int32_t>(origin[axis]);
    slot.cells[axis] = static_cast<int16_t>(std::min(this->Edge[axis], cellsAlong(layout.dims[axis]) - origin[axis]));
    slot.cellCount *= std::max<int32_t>(1, slot.cells[axis]);
    size[axis] = slot.cells[axis] + 1;
  }
}

void BlockBuffer::load(int64_t slotIndex, uint64_t blockIndex)
{
  std::array<int64_t, 3> origin{}, size{};
  this->place(slotIndex, blockIndex, origin, size);
  this->Reader.readBox(origin, size, this->samplesOf(slotIndex)); // within the slot's share of the arena
  ++this->BlocksRead;
}

int64_t BlockBuffer::drawPosition(uint64_t seed, uint64_t step, uint64_t index) const
{
  const int64_t resident = static_cast<int64_t>(this->Resident.size());
  constexpr uint64_t kAttempts = 64; // a far-face block is rarely below 1/64 of a full one; then it is kept anyway
  for (uint64_t attempt = 0;; ++attempt)
  {
    const uint64_t draw = index * kAttempts + attempt;
    const int64_t position = randomBankIndex(seed, step, draw, resident);
    const Slot& slot = this->Slots[static_cast<size_t>(this->Resident[static_cast<size_t>(position)])];
    if (slot.cellCount == this->FullCellCount || attempt + 1 == kAttempts ||
      randomBankIndex(seed ^ 0xACCE97ull, step, draw, this->FullCellCount) < slot.cellCount)
      return position;
  }
}

void BlockBuffer::drawSamples(int64_t count, uint64_t seed, uint64_t step, float* xyz, float* values,
  int64_t first) const
{
  const int64_t* dims = this->Reader.layout().dims;
  for (int64_t i = 0; i < count; ++i)
  {
    const uint64_t index = static_cast<uint64_t>(first + i);
    const int64_t slotIndex = this->Resident[static_cast<size_t>(this->drawPosition(seed, step, index))];
    const Slot& slot = this->Slots[static_cast<size_t>(slotIndex)];
    float u[3];
    int64_t base[3];
    float t[3];
    for (int axis = 0; axis < 3; ++axis)
    {
      const uint64_t h = mix64(mix64(seed ^ (step * 0x9E3779B97F4A7C15ull)) + 3 * index + static_cast<uint64_t>(axis));
      u[axis] = unitFloat(h) * static_cast<float>(slot.cells[axis]);
      base[axis] = std::min<int64_t>(static_cast<int64_t>(u[axis]), std::max<int64_t>(0, slot.cells[axis] - 1));
      t[axis] = slot.cells[axis] == 0 ? 0.0f : u[axis] - static_cast<float>(base[axis]);
      const int64_t cells = cellsAlong(dims[axis]);
      xyz[3 * i + axis] = cells == 0 ? 0.5f
                                     : static_cast<float>((static_cast<double>(slot.origin[axis]) + u[axis]) /
                                         static_cast<double>(cells));
    }
    const int64_t nx = slot.cells[0] + 1, ny = slot.cells[1] + 1;
    const int64_t step1[3] = { slot.cells[0] > 0 ? 1 : 0, slot.cells[1] > 0 ? nx : 0, slot.cells[2] > 0 ? nx * ny : 0 };
    const float* corner = this->samplesOf(slotIndex) + (base[2] * ny + base[1]) * nx + base[0];
    float value = 0.0f;
    for (int c = 0; c < 8; ++c)
    {
      const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
      const float weight = (dx ? t[0] : 1.0f - t[0]) * (dy ? t[1] : 1.0f - t[1]) * (dz ? t[2] : 1.0f - t[2]);
      value += weight * corner[dx * step1[0] + dy * step1[1] + dz * step1[2]];
    }
    values[i] = value;
  }
}

void BlockBuffer::advance(int blocks)
{
  std::unique_lock<std::mutex> lock(this->Mutex);
  if (this->ReaderError)
    std::rethrow_exception(this->ReaderError);
  if (this->Free.empty() && this->Ready.empty())
    return; // the whole volume is resident
  const int64_t resident = static_cast<int64_t>(this->Resident.size());
  for (int k = 0; k < blocks; ++k)
  {
    if (this->Ready.empty() && this->Readers.empty() && !this->Free.empty())
    {
      // No reader thread could be made: read here.
      const int64_t slot = this->Free.back();
      this->Free.pop_back();
      this->load(slot, this->randomBlock(this->NextDraw++));
      this->Ready.push_back(static_cast<int32_t>(slot));
    }
    if (this->Ready.empty())
    {
      ++this->SwapsMissed;
      continue;
    }
    const int64_t loaded = this->Ready.back();
    this->Ready.pop_back();
    const int64_t position = randomBankIndex(this->Config.seed, 0x5A9, this->SwapDraw++, resident);
    this->Free.push_back(this->Resident[static_cast<size_t>(position)]);
    this->Resident[static_cast<size_t>(position)] = static_cast<int32_t>(loaded);
    this->markResident(loaded);
    ++this->BlocksSwapped;
  }
  lock.unlock();
  this->Wake.notify_all();
}

void BlockBuffer::readerLoop()
{
#ifdef __linux__
  // Below the trainer's threads (this thread alone; BlockBufferConfig::readerNice): the H100 crop with 14 readers at
  // the GPU trainer's priority kept 49-61% of the in-memory step rate, at nice +10 58-69%.
  if (this->Config.readerNice > 0)
    ::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), this->Config.readerNice);
#endif
  std::unique_lock<std::mutex> lock(this->Mutex);
  for (;;)
  {
    this->Wake.wait(lock, [this]() { return this->Stopping || (!this->Free.empty() && !this->ReaderError); });
    if (this->Stopping)
      return;
    const int64_t slot = this->Free.back();
    this->Free.pop_back();
    const uint64_t block = this->randomBlock(this->NextDraw++);
    lock.unlock();
    try
    {
      this->load(slot, block);
    }
    catch (...)
    {
      lock.lock();
      this->ReaderError = std::current_exception();
      this->Free.push_back(static_cast<int32_t>(slot));
      continue;
    }
    lock.lock();
    this->Ready.push_back(static_cast<int32_t>(slot));
  }
}

int64_t BlockBuffer::bytesPerSlot(int blockCells)
{
  return bytesPerSlot(blockCells, blockCells, blockCells);
}

int64_t BlockBuffer::bytesPerSlot(int cellsX, int cellsY, int cellsZ)
{
  const int64_t samples = (int64_t(cellsX) + 1) * (int64_t(cellsY) + 1) * (int64_t(cellsZ) + 1);
  return samples * static_cast<int64_t>(sizeof(float)) + static_cast<int64_t>(sizeof(Slot) + sizeof(int32_t));
}

BlockBufferStats BlockBuffer::stats() const
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  BlockBufferStats s;
  s.residentBlocks = static_cast<int64_t>(this->Resident.size());
  s.loadingSlots = static_cast<int64_t>(this->Slots.size() - this->Resident.size());
  s.blocksRead = this->BlocksRead.load();
  s.blocksSwapped = this->BlocksSwapped;
  s.swapsMissed = this->SwapsMissed;
  s.bytesRead = this->Reader.bytesRead();
  s.bytesTransferred = this->Reader.bytesTransferred();
  s.pageCache = this->Reader.pageCache();
  s.blockCount = this->BlockCount;
  s.blocksEverResident = this->EverResident.empty() ? -1 : this->EverResidentCount;
  for (int axis = 0; axis < 3; ++axis)
    s.blockCells[axis] = static_cast<int>(this->Edge[axis]);
  s.bufferBytes = static_cast<int64_t>(this->Arena.capacity() * sizeof(float) + this->Slots.capacity() * sizeof(Slot) +
    (this->Resident.capacity() + this->Free.capacity() + this->Ready.capacity()) * sizeof(int32_t));
  return s;
}

} // namespace nv
