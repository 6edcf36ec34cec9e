// NeuralVolume GPU tests and benchmarks: probes into the CUDA engine's internals (plain C++ declarations). They are
// built into the test and benchmark executables only (Testing/Gpu/GpuTestHooks.cu), never into the engine.
#pragma once

#include "Core/Denoise.h"
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
/// (Trainer::lossAndGradient of a GPU trainer on a throwaway 2^3 volume).
float testLossAndGradient(const Model& model, const TrainConfig& config, const float* xyz, const float* targets,
  const uint8_t* valid, int64_t n, std::vector<float>& grad, const KernelOptions& kernels = KernelOptions());

/// Bits per axis of the Morton bins inference uses for n points under KernelOptions::binBitsPerAxis `forced`.
int inferenceBinning(int64_t n, int forced);

/// The fused forward (decode) kernel's plan for this model and options: weights in shared memory or not, and its
/// dynamic shared memory in bytes.
bool forwardWeightsShared(const Model& model, const KernelOptions& options, int* bytes);

/// Kernel-only timings (device-resident inputs and outputs, CUDA events, median of `reps`), milliseconds.
double benchInferKernel(const Model& model, int64_t n, int reps, const KernelOptions& options = KernelOptions());
double benchDecodeKernel(const Model& model, int64_t nx, int64_t ny, int64_t nz, int reps,
  const KernelOptions& options = KernelOptions());

/// Public-API timings through a session on device arrays (random points / a grid written to device memory; each
/// call synchronises, host wall clock, median of `reps`), milliseconds.
double benchSessionInfer(NetworkSession& session, int64_t n, int reps);
double benchSessionDecode(NetworkSession& session, int64_t nx, int64_t ny, int64_t nz, int reps);

/// Copy n floats of device memory to the host (tests of device-memory outputs); `ready` (RenderResult::deviceReady):
/// after that event.
void copyToHost(const float* device, size_t n, float* host, const void* ready = nullptr);

/// The CUDA path-tracing denoiser (GpuDenoiser) on host images: uploads, denoises, downloads into out
/// (width x height x 4); moments may be null with params.frames < 2.
void testDenoise(const DenoiseParams& params, const float* noisy, const float* guide, const float* moments,
  float* out);

} // namespace gpu
} // namespace nv
