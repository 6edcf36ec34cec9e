// NeuralVolume engine: entry points of the CUDA implementation (compiled only with NV_WITH_CUDA).
// Plain C++ declarations: the VTK-free Core dispatches here without seeing any CUDA header.
#pragma once

#include "Core/Engine.h"
#include "Core/NetworkSession.h"

#include <functional>
#include <memory>
#include <string>

namespace nv
{
namespace gpu
{

/// True when the CUDA runtime finds device `ordinal` (-1: the calling thread's current device) and this build can
/// run on it (compute capability 7.5 or newer, with code for it in the build); otherwise `why` says what is
/// missing, in one sentence. The first query of a device makes it the calling thread's current device.
bool deviceUsable(std::string* why, int ordinal = -1);

/// CUDA devices the runtime sees (0 without a driver or a GPU).
int deviceCount();

/// Name, architecture, multiprocessors and memory of the current device, for reports.
std::string deviceDescription();

/// Receives a trainer's fp32 parameters (device pointer, Model::params layout) and the trainer's stream on publish().
using PublishFn = std::function<void(const float* deviceParams, void* stream)>;

std::unique_ptr<Trainer> createTrainer(const Model& model, const VolumeView& volume, const TrainConfig& config,
  const KernelOptions& options, PublishFn publish);
/// A trainer on a bank of points, uploaded once (GPU-resident).
std::unique_ptr<Trainer> createTrainer(const Model& model, const TrainingPoints& points, const TrainConfig& config,
  const KernelOptions& options, PublishFn publish);
/// A trainer on out-of-core batches (BatchSource.h): drawn on the host, positions and targets copied each step.
std::unique_ptr<Trainer> createTrainer(const Model& model, BatchSource& source, const TrainConfig& config,
  const KernelOptions& options, PublishFn publish);

} // namespace gpu
} // namespace nv
