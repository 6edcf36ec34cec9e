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
  const Model& model() const override { return M; }
  uint64_t version() const override;
  void setModel(const Model& model) override;
  void syncModel() override {}
  Model currentModel() override;
  std::unique_ptr<Trainer> createTrainer(const VolumeView& volume, const TrainConfig& config) override;
  std::unique_ptr<Trainer> createTrainer(const TrainingPoints& points, const TrainConfig& config) override;
  void inferPoints(const float* xyz, int64_t n, float* out, Memory where) override;
  void decodeGrid(int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out, Memory where) override;
  void render(const RenderRequest& request, RenderResult& result, Memory where) override;
  bool workPending() const override;
  int64_t deviceMemoryBytes() const override { return 0; }

private:
  /// Makes a trainer's parameters the session's.
  CpuTrainer::PublishFn publisher();
  /// The evaluator of the current parameters (rebuilt after a change). Call with Mutex held.
  const CpuInference& evaluator();

  SessionOptions Options;
  mutable std::mutex Mutex;
  Model M;
  /// Changed under Mutex; read without it (a render in flight on another thread holds Mutex: a caller that only asks
  /// for the version or for pending work must not wait for that render).
  std::atomic<uint64_t> Version{ 1 };
  ThreadPool Pool;
  std::unique_ptr<CpuInference> Eval;
  std::unique_ptr<CpuRenderer> Renderer;
};

} // namespace nv
