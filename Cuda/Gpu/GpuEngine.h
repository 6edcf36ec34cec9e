// NeuralVolume engine: entry points of the CUDA implementation (compiled only with NV_WITH_CUDA).
// Plain C++ declarations: the VTK-free Core dispatches here without seeing any CUDA header.
#pragma once

#include "Core/Engine.h"

#include <memory>
#include <string>

namespace nv
{
namespace gpu
{

/// True when the CUDA runtime finds a usable device (sm_90 build: compute capability 9.x).
bool deviceUsable(std::string* why);

std::unique_ptr<Trainer> createTrainer(const Model& model, const VolumeView& volume, const TrainConfig& config);

/// Normalised network outputs.
void inferPoints(const Model& model, const float* xyz, int64_t n, float* out);
void decodeGrid(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out);

} // namespace gpu
} // namespace nv
