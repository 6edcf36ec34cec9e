// Crafted model files for the serialization tests: byte offsets of the format, patching helpers, a small network,
// and an allocation tracker that checks a reader refuses a crafted file before any large allocation.
// Include from exactly one source file per test executable: it replaces the global operator new and delete.
#pragma once

#include "Core/Error.h"
#include "Core/Serialization.h"
#include "TestHarness.h"

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

// Every allocation of this process goes through these (the engine's too, static or shared): while armed they record
// the largest single request.
namespace
{
std::atomic<bool> gTrackAllocations{ false };
std::atomic<size_t> gLargestAllocation{ 0 };
} // namespace

void* operator new(size_t n)
{
  if (gTrackAllocations.load(std::memory_order_relaxed))
  {
    size_t seen = gLargestAllocation.load();
    while (n > seen && !gLargestAllocation.compare_exchange_weak(seen, n))
    {
    }
  }
  if (void* p = std::malloc(n ? n : 1))
    return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept
{
  std::free(p);
}
void operator delete(void* p, size_t) noexcept
{
  std::free(p);
}

namespace
{
/// The reader of a crafted file may allocate the header's strings and its error message, nothing like a table:
/// every crafted case must throw before any single allocation above this.
constexpr size_t kCraftedAllocationCap = 64 * 1024;

// Offsets in a serialized model: magic (8), version (4), header size (4), then the header's fields.
constexpr size_t kAtVersion = 8, kAtHeaderBytes = 12, kAtLevels = 16, kAtFeatures = 20, kAtLog2Table = 24,
                 kAtPerLevelScale = 32, kAtFinest = 40, kAtPrecision = 52, kAtDims = 56, kAtOrigin = 80,
                 kAtSpacing = 104, kAtBounds = 128, kAtValueMin = 176, kAtAssociation = 192, kAtNameLength = 204;

/// A small network (8592 parameters, about 17 KB stored in fp16) on a 64 x 32 x 7 grid, stored in `storage`.
nv::Model craftedModel(nv::Precision storage)
{
  nv::ModelConfig c;
  c.encoding.levels = 4;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = 10;
  c.encoding.finestResolution = 64;
  c.network.width = 16;
  c.network.hiddenLayers = 2;
  nv::Model m(c);
  m.initialize(7);
  m.source.dims[0] = 64;
  m.source.dims[1] = 32;
  m.source.dims[2] = 7;
  m.source.spacing[0] = 0.5;
  for (int a = 0; a < 3; ++a)
    m.source.bounds[2 * a + 1] = (m.source.dims[a] - 1) * m.source.spacing[a];
  m.source.arrayName = "rho";
  m.quantize(storage);
  return m;
}

template <typename T>
void patch(std::vector<uint8_t>& b, size_t at, T v)
{
  std::memcpy(b.data() + at, &v, sizeof(T));
}

template <typename T>
T peek(const std::vector<uint8_t>& b, size_t at)
{
  T v;
  std::memcpy(&v, b.data() + at, sizeof(T));
  return v;
}

/// Recompute the checksum, so that the reader's field checks (not the checksum) meet the crafted content.
void fixChecksum(std::vector<uint8_t>& b)
{
  patch<uint32_t>(b, b.size() - 4, nv::crc32(b.data(), b.size() - 4));
}

/// Offset of the parameter count: after the magic, version, header size and the header.
size_t parameterCountAt(const std::vector<uint8_t>& b)
{
  return 16 + peek<uint32_t>(b, kAtHeaderBytes);
}

/// Deserializes `bytes` expecting an nv::Error containing `message`; fails when a single allocation above
/// kCraftedAllocationCap happened first (the message names the case).
void expectRefused(const std::vector<uint8_t>& bytes, const std::string& message, const char* what)
{
  gLargestAllocation = 0;
  gTrackAllocations = true;
  std::string got = "(no error)";
  bool nvError = false;
  try
  {
    nv::deserialize(bytes);
  }
  catch (const nv::Error& e)
  {
    nvError = true;
    got = e.what();
  }
  catch (const std::exception& e)
  {
    got = std::string("not an nv::Error: ") + e.what();
  }
  gTrackAllocations = false;
  const size_t largest = gLargestAllocation;
  if (!nvError || got.find(message) == std::string::npos)
    nvtest::fail(__FILE__, __LINE__, std::string(what) + ": expected '" + message + "', got '" + got + "'");
  if (largest > kCraftedAllocationCap)
    nvtest::fail(__FILE__, __LINE__, std::string(what) + ": allocated " + std::to_string(largest) + " bytes at once");
}
} // namespace
