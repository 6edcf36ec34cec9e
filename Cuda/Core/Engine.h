// NeuralVolume engine: device choice, the trainer interface and error statistics. Networks are used through a
// NetworkSession (NetworkSession.h), which creates trainers and does inference, decoding and rendering:
//   auto session = nv::NetworkSession::create(nv::Device::Auto, model);
//   auto trainer = session->createTrainer(volume, trainConfig);
//   trainer->steps(1000, nullptr);
//   trainer->publish();                     // the session now holds the trained parameters
#pragma once

#include "Config.h"
#include "Model.h"
#include "Volume.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nv
{

/// True when CUDA device `cudaDevice` is usable (built with CUDA, driver present, a supported GPU); -1: the calling
/// thread's current device. The first query of a device makes it the calling thread's current device (no context is
/// made on another one).
bool cudaAvailable(std::string* why = nullptr, int cudaDevice = -1);
/// CUDA devices this process sees (0 in a build without CUDA, without a driver or a GPU). The CUDA runtime reads
/// CUDA_VISIBLE_DEVICES, which a launcher may set per process; the engine reads no environment variable itself.
int cudaDeviceCount();
/// Creates the CUDA context of device `cudaDevice` (-1: the calling thread's current one) when CUDA is usable there,
/// so that the first session made afterwards does not wait for it (0.2 s on an H100); callable from any thread (a
/// background thread while a state loads); nothing in a build without CUDA or without a GPU. Never throws.
void cudaCreateContext(int cudaDevice = -1) noexcept;
/// Auto -> Cuda when device `cudaDevice` is available, else Cpu. Cuda when unavailable throws.
Device resolveDevice(Device requested, std::string* message = nullptr, int cudaDevice = -1);

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
  /// Update OptimizerConfig::plannedSteps (counted from this trainer's first step) of an annealed schedule while
  /// training, e.g. as a time budget's measured step rate refines the estimate; finite and >= 0 (0: not known).
  virtual void setPlannedSteps(double steps) = 0;
  /// Copy the current parameters into `model` (same configuration as the one trained).
  virtual void syncTo(Model& model) const = 0;
  /// Make the current parameters those of the session that created this trainer (in place: on the GPU without
  /// leaving the device); the session's version() changes. Training can go on afterwards.
  virtual void publish() = 0;
  virtual Device device() const = 0;
  /// Bytes of accelerator memory held (0 on the CPU).
  virtual int64_t deviceMemoryBytes() const { return 0; }
  /// Loss and dL/dparams (Model::params layout: encoding, then MLP) of the current parameters on a given batch of
  /// 1..batchSize samples (xyz: n x 3 host floats in [0,1]^3, normalised targets, valid flags), without an update;
  /// for gradient checks between backends. Call between steps. When the next step trains through the stored network
  /// (TrainConfig::quantizationAwareFraction), so does this.
  virtual float lossAndGradient(const float* xyz, const float* targets, const uint8_t* valid, int64_t n,
    std::vector<float>& grad) = 0;
};

/// Error against a source volume over every valid voxel (values normalised by the source range):
/// PSNR = 10 log10(1 / MSE), and the max abs error in source units.
struct ErrorStats
{
  double psnr = 0.0;
  double mse = 0.0;
  double maxAbsError = 0.0;
  /// The max abs error in units of the range (max |error| / (max - min); a constant field: in source units): finite
  /// where maxAbsError is not representable (an error above DBL_MAX in a range wider than the largest double).
  double maxErrorOfRange = 0.0;
  int64_t count = 0;
  /// Valid source samples where the network's value is NaN or Inf (a diverged network): then psnr and mse are NaN
  /// and maxAbsError and maxErrorOfRange are +inf -- never a perfect score. count includes them.
  int64_t nonFinite = 0;
};
/// Error of an already decoded grid of the source resolution (source units) against the source.
ErrorStats compareDecoded(const float* decoded, const VolumeView& volume, double valueMin, double valueMax,
  int threads = 0);
ErrorStats compareDecoded(const double* decoded, const VolumeView& volume, double valueMin, double valueMax,
  int threads = 0);

} // namespace nv
