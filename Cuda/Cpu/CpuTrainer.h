// NeuralVolume engine: training on the CPU (multithreaded; deterministic for a seed and thread count).
#pragma once

#include "Core/BatchSource.h"
#include "Core/Engine.h"
#include "Core/PlateauSchedule.h"
#include "CpuAdam.h"
#include "CpuImportance.h"
#include "CpuMlp.h"
#include "Core/TrainingPoints.h"
#include "ThreadPool.h"

#include <functional>
#include <vector>

namespace nv
{

class CpuTrainer final : public Trainer
{
public:
  /// Receives the parameters on publish() (the session that created the trainer).
  using PublishFn = std::function<void(const std::vector<float>& params)>;

  /// Trains on `volume` (targets interpolated at random points), or on `points` when it holds any (each step draws
  /// its batch from the bank); either must outlive the trainer.
  CpuTrainer(const Model& model, const VolumeView& volume, const TrainingPoints& points, const TrainConfig& config,
    PublishFn publish);

  float step() override;
  int64_t stepsDone() const override { return Steps; }
  double currentLearningRate() const override
  {
    return Train.optimizer.learningRateAt(Steps + 1) * Plateau.scale();
  }
  void setPlannedSteps(double steps) override
  {
    TrainConfig changed = Train;
    changed.optimizer.plannedSteps = steps;
    validate(changed); // finite, >= 0; > 0 for an explicitly annealed schedule
    Train.optimizer.plannedSteps = steps;
    Adam.setPlannedSteps(steps);
  }
  void syncTo(Model& model) const override;
  void publish() override;
  Device device() const override { return Device::Cpu; }

  float lossAndGradient(const float* xyz, const float* targets, const uint8_t* valid, int64_t n,
    std::vector<float>& grad) override;
  /// Draw every batch from `source` instead (BatchSource.h; it must outlive the trainer).
  void setBatchSource(BatchSource* source) { Source = source; }

private:
  /// `params`: the parameters the forward and backward passes read (Params, or Stored while quantisation-aware).
  float forwardBackward(const float* params, int64_t n, int64_t nValid, bool measure = false);
  /// Whether step `step` trains through the stored network (TrainConfig::quantizationAwareFraction).
  bool quantizationAware(int64_t step) const;
  /// Stored: Params as the 8-bit network holds them (the table's codes' values, the MLP in fp16).
  void quantizeForward();

  static constexpr int kTile = 64;
  ModelConfig Config;
  GridLayout Layout;
  CpuMlp Mlp;
  TrainConfig Train;
  VolumeView Volume;
  TrainingPoints Points;
  BatchSource* Source = nullptr; ///< out-of-core batches (setBatchSource), else Volume or Points
  ThreadPool Pool;
  std::vector<float> Params;
  std::vector<float> Grad;
  std::vector<float> Stored; ///< quantisation-aware steps: the parameters of the stored network (quantizeForward)
  std::vector<float> TransposedWeights; ///< the MLP's layers transposed, [in][out] (CpuMlp::transpose)
  std::vector<float> Xyz;
  std::vector<float> Targets;
  std::vector<uint8_t> Valid;
  std::vector<float> DEnc;
  struct Scratch
  {
    std::vector<float> enc, acts, out, dOut, tmp, dW;
    double loss = 0.0;
  };
  std::vector<Scratch> Work;
  CpuAdam Adam;
  PlateauSchedule Plateau;
  CpuImportance Importance; ///< error-guided sampling (TrainConfig::importanceGrid; volumes only)
  PublishFn Publish;
  int64_t Steps = 0;
};

} // namespace nv
