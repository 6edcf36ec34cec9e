// NeuralVolume engine: arguments and launch of the In-Shader render kernel (GpuRenderInShader.cu).
#pragma once

#include "Core/RayState.h"
#include "GpuInternal.cuh"

namespace nv
{
namespace gpu
{

struct RenderCounters;

struct InShaderArgs
{
  ray::Params rayParams;
  GridLayout grid;
  MlpShape shape;
  const __half* table16;
  const __half* w16;
  const float* wout;
  int wOff[kMaxHidden];              ///< shared-memory layer offsets (halves)
  int ldE, woutOff, encOff, qOff, vOff; ///< shared-memory layout (halves; bytes)
  uint32_t total;                    ///< rays (pixels) of this pass
  uint32_t sample;                   ///< path index within the pixel
  RenderCounters* counters;
  float4* image;
  float4* accum; ///< path tracing: accumulation buffer (null: write image)
};

/// Fills the model fields and the shared-memory layout of `a`, then launches; blocksUsed receives the grid size.
void launchInShader(const DeviceModel& dm, InShaderArgs& a, cudaStream_t stream, int* blocksUsed = nullptr);

} // namespace gpu
} // namespace nv
