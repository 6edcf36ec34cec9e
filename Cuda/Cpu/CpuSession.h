// NeuralVolume engine: the CPU backend of NetworkSession (the host model, one thread pool, the renderer).
#pragma once

#include "Core/NetworkSession.h"
#include "CpuInference.h"
#include "CpuRenderer.h"
#include "CpuTrainer.h"
#include "ThreadPool.h"

#include <atomic>
#include <memory>
#include <mutex>

namespace nv
{

class CpuSession final : public NetworkSession
{
public:
  CpuSession(const Model& model, const SessionOptions& options);
  ~CpuSession() override;

  Device device() const override { return Device::Cpu; }
  const Model& model() const override { return SessionModel; }
  uint64_t version() const override;
  void setModel(const Model& model) override;
  void syncModel() override {}
  Model currentModel() override;
  std::unique_ptr<Trainer> createTrainer(const VolumeView& volume, const TrainConfig& config) override;
  std::unique_ptr<Trainer> createTrainer(const TrainingPoints& points, const TrainConfig& config) override;
  std::unique_ptr<Trainer> createTrainer(BatchSource& source, const TrainConfig& config) override;
  void inferPoints(const float* xyz, int64_t n, float* out, Memory where) override;
  void decodeGrid(int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out, Memory where) override;
  void render(const RenderRequest& request, RenderResult& result, Memory where) override;
  bool workPending() const override;
  int64_t deviceMemoryBytes() const override { return 0; }
  std::shared_ptr<const ErrorCorrections> errorCorrections() const override;

private:
  /// Makes a trainer's parameters the session's.
  CpuTrainer::PublishFn publisher();
  /// The network of the moment, copied once per version: renders and inference use it without holding Mutex, so a
  /// trainer publishing and a caller asking for the model never wait for a render in flight.
  struct Snapshot
  {
    std::shared_ptr<const Model> model;
    uint64_t version = 0;
  };
  Snapshot snapshot();
  /// The evaluator of a snapshot (rebuilt for another one). Call with WorkMutex held.
  const CpuInference& evaluator(const std::shared_ptr<const Model>& model);

  SessionOptions Options;
  mutable std::mutex Mutex; ///< SessionModel, Version, LastSnapshot: held briefly, never during a render or inference
  Model SessionModel;
  std::shared_ptr<const ErrorCorrections> Corrections; ///< of SessionModel's parameters; null once a trainer publishes
  /// Changed under Mutex; read without it.
  std::atomic<uint64_t> Version{ 1 };
  Snapshot LastSnapshot;
  /// One piece of work on the pool at a time (renders, inference, decoding): the pool, the renderer's caches and the
  /// evaluator belong to it.
  std::mutex WorkMutex;
  ThreadPool Pool;
  std::unique_ptr<CpuInference> Evaluator;
  std::shared_ptr<const Model> EvaluatorModel; ///< the snapshot Evaluator was built from
  std::unique_ptr<CpuRenderer> Renderer;
};

} // namespace nv
