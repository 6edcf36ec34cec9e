// NeuralVolume engine: a network session -- one trained (or training) network living on its device.
//
// The session owns the model's device copy, its streams, scratch buffers and thread pool, created once. Every use
// of a network goes through it: training (createTrainer: the trainer optimises the session's network and
// publish() makes its parameters the session's without leaving the device), PSNR probes and point inference,
// grid decoding, and rendering by every path. A backend (CPU or CUDA) is chosen once, by create().
//
//   auto s = nv::NetworkSession::create(nv::Device::Auto, model);
//   auto t = s->createTrainer(volume, trainConfig);
//   t->steps(500, nullptr); t->publish();   // the session now renders / decodes the trained network
//   s->render(request, result);
#pragma once

#include "BatchSource.h"
#include "Config.h"
#include "Engine.h"
#include "Model.h"
#include "Render.h"
#include "TrainingPoints.h"
#include "Volume.h"

#include <cstdint>
#include <memory>

namespace nv
{

/// Explicit variants of the GPU kernels (tests and benchmarks choose them; the defaults are the measured best).
/// The CPU backend ignores them.
struct KernelOptions
{
  /// Inference: 0 fused encode + MLP for all inputs; 1 two passes (level-major encode, then MLP) for point arrays
  /// and fused for grids; 2 two passes for both.
  int forwardMode = 1;
  int binBitsPerAxis = -1;        ///< Morton binning of point arrays: -1 auto (from 2^18 points), 0 off, 1..8 bits
  int encodeLevelsPerThread = 4;  ///< level-major encode: 1, 2 or 4 levels per thread
  int encodeScratchMiB = 512;     ///< two-pass inference: encodings scratch (allocated on first use; 512 MiB holds
                                  ///< one Sample Streaming batch of 2^23 queries of 32 halves, measured on the H100)
  int trainTwoPass = -1;          ///< -1 auto (tables > 16 MiB and batches > 32768), 0 fused, 1 two passes
  bool trainRegisterResident = true; ///< false: the WMMA training kernel
  bool inShaderHalfAccumulate = true; ///< In-Shader path: fp16 accumulation in the MLP (fewer registers per ray)
  /// Dynamic shared memory per block the kernels may use, bytes: 0 = the GPU's opt-in maximum (227 KiB on Hopper,
  /// 99 KiB on Ampere sm_86 and Ada, 64 KiB on Turing); a smaller value makes every kernel choose the tiling it
  /// would choose on a GPU with that limit.
  int sharedMemoryLimit = 0;
  /// Sample Streaming on the GPU: queries of one wavefront batch at most (0: 2^23); smaller values run more,
  /// smaller batches (a test's way to give a small image several batches per wavefront).
  int64_t streamBatchQueries = 0;
};

struct SessionOptions
{
  int threads = 0; ///< CPU worker threads (CPU backend, and host-side work of the GPU backend); 0 = all cores
  /// The CPU backend's workers run at a lower scheduling priority (ThreadPriority.h): a session beside a GUI.
  bool lowPriority = false;
  /// CUDA backend: the device ordinal the session runs on (0 .. cudaDeviceCount() - 1), chosen once: its network,
  /// streams, buffers and trainers live there, and every call selects it on the calling thread. -1: the calling
  /// thread's current device at create() (device 0 unless the application chose another). Device::Auto falls back
  /// to the CPU when this device is not usable. The CPU backend ignores it. Under MPI the application gives each
  /// rank its own (the ParaView plugin: the rank's index among the ranks of its host modulo the devices it sees).
  int cudaDevice = -1;
  KernelOptions kernels;
};

class NetworkSession
{
public:
  /// Device::Auto picks CUDA when the GPU options.cudaDevice is usable, else the CPU (`message` says why);
  /// Device::Cuda without it throws nv::Error.
  static std::unique_ptr<NetworkSession> create(Device device, const Model& model,
    const SessionOptions& options = SessionOptions(), std::string* message = nullptr);

  virtual ~NetworkSession() = default;
  NetworkSession(const NetworkSession&) = delete;
  NetworkSession& operator=(const NetworkSession&) = delete;

  virtual Device device() const = 0;
  /// The CUDA device ordinal this session runs on; -1 on the CPU.
  virtual int cudaDevice() const { return -1; }
  /// Host copy: configuration and source information; its parameters are current after setModel() or syncModel().
  virtual const Model& model() const = 0;
  /// Incremented whenever the parameters change (setModel, Trainer::publish). Caches key on it.
  virtual uint64_t version() const = 0;
  /// Replace the network (any configuration): one upload.
  virtual void setModel(const Model& model) = 0;
  /// Copy the current (published) parameters into model().
  virtual void syncModel() = 0;
  /// A copy of the current (published) network; safe while a trainer publishes from another thread (model() is
  /// not: use it only where nothing else changes the session).
  virtual Model currentModel() = 0;

  /// A trainer of this session's network on `volume` (which must outlive it). Its publish() makes the current
  /// parameters the session's, in place.
  virtual std::unique_ptr<Trainer> createTrainer(const VolumeView& volume, const TrainConfig& config) = 0;
  /// A trainer on a bank of points (TrainingPoints.h; must outlive it): each step draws its batch from the bank. The
  /// CUDA backend keeps the bank in GPU memory (TrainConfig::strategy is ignored).
  virtual std::unique_ptr<Trainer> createTrainer(const TrainingPoints& points, const TrainConfig& config) = 0;
  /// A trainer on a source of batches it does not hold (BatchSource.h: out-of-core training from a file); the source
  /// must outlive it. The CUDA backend copies each host batch (positions and targets) to the GPU, the next one
  /// prepared while the GPU trains (TrainConfig::strategy is ignored).
  virtual std::unique_ptr<Trainer> createTrainer(BatchSource& source, const TrainConfig& config) = 0;

  /// Network output (normalised units) at n points (xyz interleaved, each in [0,1]); xyz and out in `where`.
  virtual void inferPoints(const float* xyz, int64_t n, float* out, Memory where = Memory::Host) = 0;
  /// Normalised outputs of slices [z0, z1) of an nx*ny*nz grid over [0,1]^3 (sample i at i/(n-1), 0.5 when n == 1),
  /// x fastest, into out (`where`).
  virtual void decodeGrid(int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out,
    Memory where = Memory::Host) = 0;

  /// Render an image (Render.h). Cached state (decoded grid, macrocells, path-tracing accumulation) is reused while
  /// the network version, the resolution and the transfer function are unchanged.
  virtual void render(const RenderRequest& request, RenderResult& result, Memory where = Memory::Host) = 0;
  /// True while background work started by render() (a progressive decode) is still running: render again to
  /// show the refined result.
  virtual bool workPending() const = 0;

  /// Bytes of accelerator memory held (0 on the CPU).
  virtual int64_t deviceMemoryBytes() const = 0;

  /// The error corrections of the current network (Model::corrections of the last setModel()), null when it has none
  /// or when a trainer published other parameters since (they were computed for the parameters set). The CPU and CUDA
  /// sessions keep them; the default (a session of tests that scripts its answers) has none.
  virtual std::shared_ptr<const ErrorCorrections> errorCorrections() const { return nullptr; }

protected:
  NetworkSession() = default;
};

/// A shared copy of model.corrections for a session (null when the mode is off): what errorCorrections() returns.
std::shared_ptr<const ErrorCorrections> sharedCorrections(const Model& model);

/// Decode slices [z0, z1) de-normalised to source units (model().source range), into host memory. On the source's own
/// grid (nx, ny, nz = model().source.dims) the model's error corrections (ErrorCorrections.h) are applied.
void decodeGridValues(NetworkSession& session, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1,
  float* out);
void decodeGridValues(NetworkSession& session, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1,
  double* out);
/// Error of the session's network against the source volume over every valid voxel (see ErrorStats).
ErrorStats compareToSource(NetworkSession& session, const VolumeView& volume);

} // namespace nv
