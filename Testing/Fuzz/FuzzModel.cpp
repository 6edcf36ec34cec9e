// libFuzzer target of the model reader (Cuda/Core/Serialization.h), built by NV_FUZZ=ON (Clang, ASan + UBSan).
//
// An input is a model's bytes; its last 4 bytes are replaced by the CRC-32 of the others before it is read, so that
// mutations reach the field checks and the parser instead of stopping at the checksum. The corpus starts from valid
// models (nvFuzzCorpus). Besides memory errors and undefined behaviour (the sanitizers), every input must satisfy:
//   - the reader throws nothing but nv::Error;
//   - an accepted model allocates exactly what inspectModel() stated (parameters and mask bits);
//   - it is written again without error, and what is written reads back to the same bytes;
//   - its masks answer lookups, and a CPU session evaluates it at a few points (the parsed configuration and grid
//     drive real code).
// A violation aborts (a crash for libFuzzer, which stores the input).
#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/Macrocells.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace
{
[[noreturn]] void violated(const char* what)
{
  std::fprintf(stderr, "fuzz property violated: %s\n", what);
  std::abort();
}

void exercise(const nv::Model& m)
{
  // Lookups at the corners and the centre of the grid, and a little outside it.
  const float points[] = { 0.f, 0.f, 0.f, 1.f, 1.f, 1.f, 0.5f, 0.25f, 0.75f, -0.5f, 1.5f, 0.5f, 1.f, 0.f, 1.f };
  const int64_t n = sizeof(points) / sizeof(points[0]) / 3;
  for (int64_t i = 0; i < n; ++i)
  {
    (void)nv::inDomain(m.source, points + 3 * i);
    if (!m.source.occupancy.empty())
    {
      const nv::MacrocellLayout cells = nv::macrocellLayout(m.source.dims);
      (void)nv::cellOccupied(m.source.occupancy.data(), cells, points[3 * i], points[3 * i + 1], points[3 * i + 2]);
    }
  }
  nv::SessionOptions options;
  options.threads = 1;
  std::unique_ptr<nv::NetworkSession> session = nv::NetworkSession::create(nv::Device::Cpu, m, options);
  float out[n];
  session->inferPoints(points, n, out);
  float grid[8];
  session->decodeGrid(2, 2, 2, 0, 2, grid);
}
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  std::vector<uint8_t> bytes(data, data + size);
  if (bytes.size() >= 4)
  {
    const uint32_t crc = nv::crc32(bytes.data(), bytes.size() - 4);
    std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  }
  nv::Model m;
  nv::ModelFileInfo info;
  try
  {
    info = nv::inspectModel(bytes.data(), bytes.size());
    m = nv::deserialize(bytes);
  }
  catch (const nv::Error&)
  {
    return 0; // refused with a message: the expected outcome for most inputs
  }
  const uint64_t held = uint64_t(m.params().size() + m.source.domain.size() + m.source.occupancy.size()) * 4;
  if (held != info.hostBytes)
    violated("the model holds other bytes than inspectModel() stated");
  if (m.params().size() != info.parameterCount)
    violated("parameter count");
  std::vector<uint8_t> again;
  try
  {
    again = nv::serialize(m);
    if (nv::serialize(nv::deserialize(again)) != again)
      violated("a written model does not read back to the same bytes");
  }
  catch (const nv::Error& e)
  {
    std::fprintf(stderr, "%s\n", e.what());
    violated("an accepted model cannot be written and read again");
  }
  try
  {
    exercise(m);
  }
  catch (const nv::Error& e)
  {
    std::fprintf(stderr, "%s\n", e.what());
    violated("an accepted model cannot be evaluated");
  }
  return 0;
}
