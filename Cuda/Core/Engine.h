// NeuralVolume engine: the public API used by the VTK layer and the tests.
//
//   nv::Model model(config);  model.initialize(seed);
//   auto trainer = nv::createTrainer(nv::Device::Auto, model, volume, trainConfig);
//   while (...) trainer->step();            // one optimisation step each
//   trainer->syncTo(model);                 // parameters back to the host model
//   nv::decodeGrid(model, nx, ny, nz, 0, nz, out, nv::Device::Auto);
#pragma once

#include "Config.h"
#include "Model.h"
#include "Volume.h"

#include <cstdint>
#include <memory>
#include <string>

namespace nv
{

/// True when a CUDA device is usable (built with CUDA, driver present, a supported GPU).
bool cudaAvailable(std::string* why = nullptr);
/// Auto -> Cuda when available, else Cpu. Cuda when unavailable throws.
Device resolveDevice(Device requested, std::string* message = nullptr);

class Trainer
{
public:
  virtual ~Trainer() = default;
  Trainer() = default;
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;

  /// One optimisation step on a fresh random batch; returns the batch loss (before the update).
  virtual float step() = 0;
  /// `count` steps back to back; losses[i] (may be null) receives the loss of the i-th. Same result as `count`
  /// calls of step(); the GPU trainer queues them all and reads the losses back once.
  virtual void steps(int64_t count, float* losses)
  {
    for (int64_t i = 0; i < count; ++i)
    {
      const float l = step();
      if (losses)
        losses[i] = l;
    }
  }
  /// Steps completed so far.
  virtual int64_t stepsDone() const = 0;
  /// Learning rate the next step will use.
  virtual double currentLearningRate() const = 0;
  /// Copy the current parameters into `model` (same configuration as the one trained).
  virtual void syncTo(Model& model) const = 0;
  virtual Device device() const = 0;
  /// Bytes of accelerator memory held (0 on the CPU).
  virtual int64_t deviceMemoryBytes() const { return 0; }
};

/// `volume` must stay alive while the trainer is used. `model` provides the configuration and
/// the initial parameters.
std::unique_ptr<Trainer> createTrainer(Device device, const Model& model, const VolumeView& volume,
  const TrainConfig& config);

/// Network output (normalised units) at n points (xyz interleaved, each in [0,1]).
void inferPoints(const Model& model, const float* xyz, int64_t n, float* out, Device device = Device::Cpu,
  int threads = 0);

/// Decode slices [zBegin, zEnd) of an nx*ny*nz grid spanning [0,1]^3 (sample i at i/(n-1); 0.5 when n == 1)
/// into `out` (x fastest, slice zBegin first), de-normalised to source units.
void decodeGrid(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t zBegin, int64_t zEnd, float* out,
  Device device = Device::Cpu, int threads = 0);
/// Same in double precision (for sources whose range does not fit in float).
void decodeGrid(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t zBegin, int64_t zEnd, double* out,
  Device device = Device::Cpu, int threads = 0);
/// Same, normalised network outputs (no de-normalisation).
void decodeGridNormalized(const Model& model, int64_t nx, int64_t ny, int64_t nz, int64_t zBegin, int64_t zEnd,
  float* out, Device device = Device::Cpu, int threads = 0);

/// Error of the model against the source volume over every valid voxel (values normalised by the source
/// range): PSNR = 10 log10(1 / MSE), and the max abs error in source units.
struct ErrorStats
{
  double psnr = 0.0;
  double mse = 0.0;
  double maxAbsError = 0.0;
  int64_t count = 0;
};
ErrorStats compareToSource(const Model& model, const VolumeView& volume, Device device = Device::Cpu,
  int threads = 0);
/// Same, for an already decoded grid of the source resolution (source units).
ErrorStats compareDecoded(const float* decoded, const VolumeView& volume, double valueMin, double valueMax,
  int threads = 0);
ErrorStats compareDecoded(const double* decoded, const VolumeView& volume, double valueMin, double valueMax,
  int threads = 0);

} // namespace nv
