// libFuzzer target of the OpenVDB header check (Cuda/Core/VdbFileCheck.h), built by NV_FUZZ=ON (Clang, ASan + UBSan).
//
// An input is a .vdb file's bytes (the seeds: valid layouts from nvFuzzVdbCorpus). The check must never read outside
// the bytes (its reads go through a function that aborts on a request past the end), throw anything but nv::Error,
// or hold more than a few clipped strings. An accepted file must satisfy what the summary promises:
//   - the grids are laid out in order: each descriptor ends where its grid starts, descriptor < grid < end <= size,
//     the data blocks within the grid (an instance's may be 0), the next descriptor at the previous grid's end;
//   - a file with grid offsets has all its declared grids checked, a streamed one its first;
//   - strings are clipped (names to kKeptChars + "...", type names to kMaxTypeNameBytes);
//   - the same bytes cut just before the last grid's end are refused (the positions are really checked).
// A violation aborts (a crash for libFuzzer, which stores the input).
#include "Core/Error.h"
#include "Core/VdbFileCheck.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace
{
[[noreturn]] void violated(const char* what)
{
  std::fprintf(stderr, "fuzz property violated: %s\n", what);
  std::abort();
}

/// The check of the first `size` bytes, every read bounded by them.
nv::VdbFileSummary check(const uint8_t* data, size_t size)
{
  nv::VdbFileCheck c(
    [data, size](uint64_t offset, void* dst, size_t n) {
      if (offset > size || n > size - offset)
        violated("a read past the bytes given");
      std::memcpy(dst, data + offset, n);
      return true;
    },
    size);
  return c.run();
}

void expectLayout(const nv::VdbFileSummary& s, size_t size)
{
  const size_t kept = nv::VdbFileCheck::kKeptChars + 3;
  if (s.fileSize != size || s.gridCount < 0 || s.grids.size() > size_t(s.gridCount))
    violated("file size or grid count");
  if (s.hasGridOffsets ? s.grids.size() != size_t(s.gridCount) : s.grids.size() > 1)
    violated("grids checked");
  uint64_t next = s.grids.empty() ? 0 : s.grids[0].descriptorPos;
  for (const nv::VdbFileSummary::Grid& g : s.grids)
  {
    if (g.name.size() > kept || g.instanceParent.size() > kept || g.type.size() > nv::VdbFileCheck::kMaxTypeNameBytes ||
      g.transformType.size() > nv::VdbFileCheck::kMaxTypeNameBytes)
      violated("a string longer than the check keeps");
    if (g.descriptorPos != next || g.descriptorPos >= g.gridPos || g.gridPos > size)
      violated("descriptor and grid positions");
    if (!s.hasGridOffsets)
      continue;
    const bool instance = !g.instanceParent.empty();
    if (g.endPos <= g.gridPos || g.endPos > size)
      violated("end position");
    if (instance ? g.blockPos != 0 && (g.blockPos < g.gridPos || g.blockPos > g.endPos)
                 : g.blockPos <= g.gridPos || g.blockPos > g.endPos)
      violated("block position");
    next = g.endPos;
  }
}
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  nv::VdbFileSummary s;
  try
  {
    s = check(data, size);
  }
  catch (const nv::Error& e)
  {
    if (std::strlen(e.what()) > 2000)
      violated("a message longer than 2000 characters");
    return 0; // refused with a message: the expected outcome for most inputs
  }
  expectLayout(s, size);
  if (s.hasGridOffsets && !s.grids.empty())
  {
    const uint64_t end = s.grids.back().endPos;
    try
    {
      (void)check(data, size_t(end - 1));
      violated("a file cut before its last grid's end was accepted");
    }
    catch (const nv::Error&)
    {
    }
  }
  return 0;
}
