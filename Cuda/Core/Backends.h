// NeuralVolume engine: entry points of the two backends. The only place the core learns which backends a build
// has: CMake compiles either the CUDA backend (Gpu/GpuSession.cu) or Cpu/NoCudaBackend.cpp, which report CUDA as
// unusable with the reason.
#pragma once

#include "NetworkSession.h"

#include <cstdint>
#include <memory>
#include <string>

namespace nv
{

/// The checked training configuration of a session's trainer: `config` validated, a non-empty volume, and the
/// session's thread count where the configuration leaves it to the session (0).
TrainConfig trainerConfig(const VolumeView& volume, const TrainConfig& config, const SessionOptions& options);
/// The same for a bank of training points: a non-empty bank with positions and values.
TrainConfig trainerConfig(const TrainingPoints& points, const TrainConfig& config, const SessionOptions& options);
/// The same for a source of batches (BatchSource.h).
TrainConfig trainerConfig(const BatchSource& source, const TrainConfig& config, const SessionOptions& options);

std::unique_ptr<NetworkSession> createCpuSession(const Model& model, const SessionOptions& options);

/// True when the CUDA backend can run here on device `cudaDevice` (-1: the current one; built with CUDA, driver
/// present, a supported GPU); else `why`.
bool cudaBackendUsable(std::string* why, int cudaDevice = -1);
/// CUDA devices the runtime sees (0 without CUDA).
int cudaBackendDeviceCount();
/// Free and total bytes of CUDA device `cudaDevice` (-1: the current one; cudaMemGetInfo); false, with both 0, in a
/// build without CUDA or when the runtime cannot answer. Creates the CUDA context where none exists; a device
/// ordinal becomes the calling thread's current device.
bool cudaDeviceMemory(int64_t& freeBytes, int64_t& totalBytes, int cudaDevice = -1);
/// Throws nv::Error when !cudaBackendUsable().
std::unique_ptr<NetworkSession> createCudaSession(const Model& model, const SessionOptions& options);

} // namespace nv
