// NeuralVolume engine: test and benchmark hooks of the CUDA implementation (plain C++; NV_WITH_CUDA builds only).
#pragma once

#include "Core/Engine.h"
#include "Core/NetworkSession.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nv
{
namespace gpu
{

/// Hash-grid encoding on the GPU as training and inference compute it (fp16 copy of the table, fp32
/// interpolation): out is n x (levels*features), same layout as CpuHashGrid::encode.
void testEncode(const Model& model, const float* xyz, int64_t n, float* out);

/// Loss and dL/dparams (layout of Model::params) of the GPU trainer for one given batch, without an update
/// (the GPU counterpart of CpuTrainer::lossAndGradient).
float testLossAndGradient(const Model& model, const TrainConfig& config, const float* xyz, const float* targets,
  const uint8_t* valid, int64_t n, std::vector<float>& grad, const KernelOptions& kernels = KernelOptions());

/// Bits per axis of the bins the last point-array inference used (0: not binned).
int lastInferenceBinning();

/// Kernel-only timings (device-resident inputs and outputs, CUDA events, median of `reps`), milliseconds.
double benchInferKernel(const Model& model, int64_t n, int reps);
double benchDecodeKernel(const Model& model, int64_t nx, int64_t ny, int64_t nz, int reps);

/// Public-API timings through a session on device arrays (random points / a grid written to device memory; each
/// call synchronises, host wall clock, median of `reps`), milliseconds.
double benchSessionInfer(NetworkSession& session, int64_t n, int reps);
double benchSessionDecode(NetworkSession& session, int64_t nx, int64_t ny, int64_t nz, int reps);

/// Copy n floats of device memory to the host (tests of device-memory outputs).
void copyToHost(const float* device, size_t n, float* host);

/// Name and memory of the device, for reports.
std::string deviceDescription();

} // namespace gpu
} // namespace nv
