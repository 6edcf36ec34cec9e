// NeuralVolume engine, out-of-core training: the random block buffer (BlockBuffer.h).
#include "BlockBuffer.h"

#include "Core/Error.h"
#include "Core/HashGridMath.h"
#include "Core/TrainingPoints.h"

#include <algorithm>
#include <system_error>

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
  : Reader(layout)
  , Config(config)
{
  NV_CHECK(config.blockCells >= 1 && config.blockCells <= 1024, "blockCells must be 1..1024");
  const int64_t edge = config.blockCells;
  int64_t samplesPerSlot = 1;
  for (int axis = 0; axis < 3; ++axis)
  {
    const int64_t cells = cellsAlong(layout.dims[axis]);
    this->BlocksPerAxis[axis] = cells == 0 ? 1 : (cells + edge - 1) / edge;
    samplesPerSlot *= std::min(cells, edge) + 1;
  }
  this->BlockCount = this->BlocksPerAxis[0] * this->BlocksPerAxis[1] * this->BlocksPerAxis[2];
  const int64_t slotBytes = samplesPerSlot * static_cast<int64_t>(sizeof(float));
  const int64_t slots = config.memoryBudgetBytes / slotBytes;
  if (slots < 2)
    NV_THROW("the out-of-core memory budget (" + std::to_string(config.memoryBudgetBytes) + " bytes) holds fewer than "
      "two blocks of " + std::to_string(slotBytes) + " bytes: raise MemoryBudget or lower the block size");
  // The loading slots asked for, else a quarter of the slots (at most four per reader), are loading while the rest
  // are drawn from; a volume whose blocks all fit is resident whole and nothing is replaced.
  int64_t loading = config.loadingSlots > 0
    ? std::min<int64_t>(config.loadingSlots, slots - 1)
    : std::max<int64_t>(1, std::min<int64_t>(slots / 4, 4 * std::max(1, config.readerThreads)));
  int64_t resident = slots - loading;
  if (resident >= this->BlockCount)
  {
    resident = this->BlockCount;
    loading = 0;
  }
  this->Slots.resize(static_cast<size_t>(resident + loading));
  for (Slot& slot : this->Slots)
    slot.samples.reserve(static_cast<size_t>(samplesPerSlot)); // all the memory, up front
  for (int64_t k = 0; k < resident; ++k)
  {
    const uint64_t block = loading == 0 ? static_cast<uint64_t>(k) : this->randomBlock(this->NextDraw++);
    this->load(this->Slots[static_cast<size_t>(k)], block);
    this->Resident.push_back(k);
  }
  for (int64_t k = resident; k < resident + loading; ++k)
    this->Free.push_back(k);
  this->weighResidents();
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

void BlockBuffer::load(Slot& slot, uint64_t blockIndex)
{
  const int64_t edge = this->Config.blockCells;
  const VolumeFileLayout& layout = this->Reader.layout();
  int64_t block[3];
  block[0] = static_cast<int64_t>(blockIndex) % this->BlocksPerAxis[0];
  block[1] = static_cast<int64_t>(blockIndex) / this->BlocksPerAxis[0] % this->BlocksPerAxis[1];
  block[2] = static_cast<int64_t>(blockIndex) / (this->BlocksPerAxis[0] * this->BlocksPerAxis[1]);
  std::array<int64_t, 3> origin{}, size{};
  for (int axis = 0; axis < 3; ++axis)
  {
    origin[axis] = block[axis] * edge;
    slot.origin[axis] = origin[axis];
    slot.cells[axis] = std::min(edge, cellsAlong(layout.dims[axis]) - origin[axis]);
    size[axis] = slot.cells[axis] + 1;
  }
  slot.samples.resize(static_cast<size_t>(size[0] * size[1] * size[2])); // within the reserved capacity
  this->Reader.readBox(origin, size, slot.samples.data());
  ++this->BlocksRead;
}

void BlockBuffer::weighResidents()
{
  this->CumulativeCells.resize(this->Resident.size());
  int64_t total = 0;
  for (size_t k = 0; k < this->Resident.size(); ++k)
  {
    const Slot& slot = this->Slots[static_cast<size_t>(this->Resident[k])];
    total += std::max<int64_t>(1, slot.cells[0]) * std::max<int64_t>(1, slot.cells[1]) *
      std::max<int64_t>(1, slot.cells[2]);
    this->CumulativeCells[k] = total;
  }
}

void BlockBuffer::drawSamples(int64_t count, uint64_t seed, uint64_t step, float* xyz, float* values,
  int64_t first) const
{
  const int64_t* dims = this->Reader.layout().dims;
  const int64_t totalCells = this->CumulativeCells.back();
  for (int64_t i = 0; i < count; ++i)
  {
    const uint64_t index = static_cast<uint64_t>(first + i);
    const int64_t cell = randomBankIndex(seed, step, index, totalCells);
    const size_t position = static_cast<size_t>(
      std::upper_bound(this->CumulativeCells.begin(), this->CumulativeCells.end(), cell) -
      this->CumulativeCells.begin());
    const Slot& slot = this->Slots[static_cast<size_t>(this->Resident[position])];
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
    const float* corner = slot.samples.data() + (base[2] * ny + base[1]) * nx + base[0];
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
      this->load(this->Slots[static_cast<size_t>(slot)], this->randomBlock(this->NextDraw++));
      this->Ready.push_back(slot);
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
    this->Resident[static_cast<size_t>(position)] = loaded;
    ++this->BlocksSwapped;
  }
  this->weighResidents();
  lock.unlock();
  this->Wake.notify_all();
}

void BlockBuffer::readerLoop()
{
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
      this->load(this->Slots[static_cast<size_t>(slot)], block);
    }
    catch (...)
    {
      lock.lock();
      this->ReaderError = std::current_exception();
      this->Free.push_back(slot);
      continue;
    }
    lock.lock();
    this->Ready.push_back(slot);
  }
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
  for (const Slot& slot : this->Slots)
    s.bufferBytes += static_cast<int64_t>(slot.samples.capacity() * sizeof(float));
  return s;
}

} // namespace nv
