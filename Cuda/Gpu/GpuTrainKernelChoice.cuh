// NeuralVolume engine: which training kernel a GPU step launches (register-resident mma.sync for widths up to 64,
// else WMMA; fused or two-pass), instantiated for every supported width and features per level, and the grid size
// of the trainer's element-wise kernels.
#pragma once

#include "GpuInternal.cuh"
#include "GpuTrainRegKernel.cuh"
#include "GpuTrainWmma.cuh"

#include <algorithm>

namespace nv
{
namespace gpu
{
namespace
{

using TrainFn = void (*)(TrainArgs);

/// Two-pass training (level-major encode -> MLP kernel -> level-major scatter) or the single fused kernel. Measured
/// on an H100 at batch 65536 (gpu_notes.md): two passes win when the table does not fit L2 comfortably (2^18: 0.557
/// vs 0.612 ms, 2^19: 0.754 vs 0.820) and lose on small tables (2^16: 0.388 vs 0.358, 2^14: 0.350 vs 0.322) and
/// small batches (16384 at 2^19: 0.501 vs 0.479; 32768: equal). KernelOptions::trainTwoPass 0 / 1 forces a path.
bool trainTwoPass(const KernelOptions& o, size_t table16Bytes, int64_t batch)
{
  if (o.trainTwoPass >= 0)
    return o.trainTwoPass != 0;
  return table16Bytes > (size_t(16) << 20) && batch > 32768;
}

TrainFn pickTrain(int W, int F, bool two)
{
#define NV_CASE(w, f)                                                                              \
  if (W == w && F == f)                                                                            \
    return two ? trainWmmaKernel<w, f, true> : trainWmmaKernel<w, f, false>;
  NV_CASE(16, 1) NV_CASE(16, 2) NV_CASE(16, 4) NV_CASE(16, 8)
  NV_CASE(32, 1) NV_CASE(32, 2) NV_CASE(32, 4) NV_CASE(32, 8)
  NV_CASE(64, 1) NV_CASE(64, 2) NV_CASE(64, 4) NV_CASE(64, 8)
  NV_CASE(128, 1) NV_CASE(128, 2) NV_CASE(128, 4) NV_CASE(128, 8)
#undef NV_CASE
  NV_THROW("unsupported network width / features per level on the GPU");
}

constexpr int kRegWarps = 8;

/// Register-resident kernel for W <= 64 (GpuTrainRegKernel.cuh); null for other widths.
TrainFn pickReg(int W, int F, bool two)
{
#define NV_CASE(w, f)                                                                              \
  if (W == w && F == f)                                                                            \
    return two ? trainRegKernel<w, f, kRegWarps, true> : trainRegKernel<w, f, kRegWarps, false>;
  NV_CASE(16, 1) NV_CASE(16, 2) NV_CASE(16, 4) NV_CASE(16, 8)
  NV_CASE(32, 1) NV_CASE(32, 2) NV_CASE(32, 4) NV_CASE(32, 8)
  NV_CASE(64, 1) NV_CASE(64, 2) NV_CASE(64, 4) NV_CASE(64, 8)
#undef NV_CASE
  return nullptr;
}

int gridFor(int64_t n, int threads = 256)
{
  const int64_t b = (n + threads - 1) / threads;
  return static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(b, int64_t(deviceInfo().sms) * 16)));
}

} // namespace
} // namespace gpu
} // namespace nv
