// NeuralVolume engine: what a GPU trainer (GpuTraining.cu) holds -- the network it trains, gradients, Adam moments,
// the batch's buffers, the host-sampling state and the training kernel's plan -- and the steps that set it up
// (allocation, the parameters' upload, the kernel's choice) and that fill a step's kernel arguments. Included by
// GpuTraining.cu only (one translation unit): GpuTrainer derives from it and adds the steps, sampling and Adam.
#pragma once

#include "Core/Config.h"
#include "Core/PlateauSchedule.h"
#include "Cpu/ThreadPool.h"
#include "GpuEngine.h"
#include "GpuInternal.cuh"
#include "GpuTrainKernelChoice.cuh"

#include <future>
#include <memory>

namespace nv
{
namespace gpu
{

class GpuTrainerState
{
protected:
  static constexpr int64_t kSlots = 256; ///< counters ring: one slot per queued step

  GpuTrainerState(const Model& model, const VolumeView& volume, const TrainingPoints& points,
    const TrainConfig& config, const KernelOptions& options, PublishFn publish, BatchSource* source)
    : Config(model.config())
    , Train(config)
    , Volume(volume)
    , Points(points)
    , Options(options)
    , Publish(std::move(publish))
    , Source(source)
  {
  }

  /// The network, its gradients and Adam moments, the batch's targets and the kernel choice.
  void allocateTraining(const Model& model, const TrainConfig& config, const KernelOptions& options)
  {
    const size_t np = model.paramCount();
    EncodingParamCount = model.encodingParamCount();
    MlpParamCount = np - EncodingParamCount;
    allocateDeviceModel(model, Network);
    Params.allocate(np, "parameters");
    TableGrad.allocate(EncodingParamCount, "hash-table gradient");
    TableMoments.allocate(EncodingParamCount, "hash-table Adam moments");
    MlpFirstMoment.allocate(MlpParamCount, "MLP Adam first moments");
    MlpSecondMoment.allocate(MlpParamCount, "MLP Adam second moments");
    GradPad.allocate(Network.shape.total, "MLP gradient");
    if (config.deterministic)
    {
      FixedTableGrad.allocate(EncodingParamCount, "fixed-point hash-table gradient (deterministic training)");
      FixedMlpGrad.allocate(Network.shape.total, "fixed-point MLP gradient (deterministic training)");
      NV_CUDA(cudaMemsetAsync(FixedTableGrad.get(), 0, FixedTableGrad.bytes(), ComputeStream.get()));
      NV_CUDA(cudaMemsetAsync(FixedMlpGrad.get(), 0, FixedMlpGrad.bytes(), ComputeStream.get()));
    }
    const int64_t B = config.batchSize;
    Targets.allocate(B, "targets");
    Network.options = options;
    if (trainTwoPass(options, Network.table16.bytes(), B))
    {
      const int64_t D = int64_t(Network.grid.levels) * Network.grid.features;
      EncG.allocate(size_t(B * D), "encodings");
      DEncG.allocate(size_t(B * D), "encoding gradients");
    }
    StepCounters.allocate(kSlots, "step counters");
    NV_CUDA(cudaMemsetAsync(StepCounters.get(), 0, StepCounters.bytes(), ComputeStream.get()));
    HostStepCounters.allocate(kSlots);
    chooseKernel(EncG.get() != nullptr, B);
  }

  /// The model's parameters into the trainer's copy (fp32 and packed), optimiser state zeroed.
  void uploadParameters(const Model& model)
  {
    NV_CUDA(cudaMemcpyAsync(Params.get(), model.params().data(), model.paramCount() * sizeof(float),
      cudaMemcpyHostToDevice, ComputeStream.get()));
    NV_CUDA(cudaMemsetAsync(TableGrad.get(), 0, TableGrad.bytes(), ComputeStream.get()));
    NV_CUDA(cudaMemsetAsync(TableMoments.get(), 0, TableMoments.bytes(), ComputeStream.get()));
    NV_CUDA(cudaMemsetAsync(MlpFirstMoment.get(), 0, MlpFirstMoment.bytes(), ComputeStream.get()));
    NV_CUDA(cudaMemsetAsync(MlpSecondMoment.get(), 0, MlpSecondMoment.bytes(), ComputeStream.get()));
    NV_CUDA(cudaMemsetAsync(GradPad.get(), 0, GradPad.bytes(), ComputeStream.get()));
    packParams(Params.get(), Network, ComputeStream.get());
    ComputeStream.sync();
    if (RegKernelPlan.warps > 0)
      Network.table16.release(); // the register-resident kernel encodes from the fp32 parameters
  }

  /// Register-resident kernel when the shape and shared memory allow, else the WMMA kernel.
  void chooseKernel(bool two, int64_t B)
  {
    const int limit = sharedMemoryLimit(Options);
    const int maxSmem = limit - 1024; // static shared memory of the kernel
    RegKernelPlan = makeRegPlan(Network.shape, kRegWarps, !two);
    TrainKernel = Options.trainRegisterResident && RegKernelPlan.warps > 0 && RegKernelPlan.total <= maxSmem
      ? pickReg(Network.shape.width, Network.grid.features, two)
      : nullptr;
    int perSm = 0;
    if (TrainKernel)
    {
      const void* fp = reinterpret_cast<const void*>(TrainKernel);
      NV_CUDA(cudaFuncSetAttribute(fp, cudaFuncAttributeMaxDynamicSharedMemorySize, RegKernelPlan.total));
      NV_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&perSm, fp, kRegWarps * 32, RegKernelPlan.total));
      if (perSm >= 1)
      {
        const int64_t iters = (B + 16 * kRegWarps - 1) / (16 * kRegWarps);
        Blocks = static_cast<int>(std::min<int64_t>(iters, int64_t(perSm) * deviceInfo().sms));
        return;
      }
    }
    RegKernelPlan = RegPlan{};
    TrainKernel = pickTrain(Network.shape.width, Network.grid.features, two);
    WmmaPlan = choosePlan(Network.shape, true, reinterpret_cast<const void*>(TrainKernel), limit, &perSm);
    const int64_t tiles = (B + WmmaPlan.tileSamples - 1) / WmmaPlan.tileSamples;
    Blocks = static_cast<int>(std::min<int64_t>(tiles, int64_t(perSm) * deviceInfo().sms));
    Slots.allocate(size_t(Blocks) * Network.shape.total, "per-block MLP gradients");
  }

  /// The training kernel's arguments for step s on n samples (its launch shape is set by launchTrain).
  TrainArgs trainArgs(const float* xyz, int64_t n, int64_t s)
  {
    TrainArgs a{};
    a.grid = Network.grid;
    a.shape = Network.shape;
    a.plan = WmmaPlan;
    for (int l = 1; l < Network.shape.hiddenLayers; ++l)
      a.actOff[l] = (l - 1) * WmmaPlan.tileSamples * WmmaPlan.ldA;
    a.reg = RegKernelPlan;
    a.table16 = Network.table16.get();
    a.table32 = Params.get();
    a.w16 = Network.w16.get();
    // fp32 output row (last MLP layer)
    a.wout = Params.get() + EncodingParamCount + (MlpParamCount - Network.shape.width);
    a.gradTable = TableGrad.get();
    a.slots = Slots.get();
    a.gradPad = GradPad.get();
    a.fixedTable = FixedTableGrad.get();
    a.fixedMlp = FixedMlpGrad.get();
    a.xyz = xyz;
    a.seed = Train.seed;
    a.step = static_cast<uint64_t>(s);
    a.targets = Targets.get();
    a.sampleCount = n;
    a.l1 = Train.loss == LossType::L1 ? 1 : 0;
    a.counters = slot(s);
    a.prev = s > 1 ? slot(s - 1) : nullptr;
    a.encG = EncG.get();
    a.dEncG = DEncG.get();
    return a;
  }

  Counters* slot(int64_t s) const { return StepCounters.get() + s % kSlots; }


  ModelConfig Config;
  TrainConfig Train;
  VolumeView Volume;
  TrainingPoints Points;
  KernelOptions Options;
  PublishFn Publish;
  BatchSource* Source = nullptr; ///< out-of-core batches (BatchSource.h); null: the volume or the points
  TrainingStrategy Strategy = TrainingStrategy::GpuResident;
  size_t EncodingParamCount = 0, MlpParamCount = 0;
  mutable Stream ComputeStream;
  DeviceModel Network;
  DeviceBuffer<float> Params, MlpFirstMoment, MlpSecondMoment, GradPad, Slots, Targets, Xyz, DEncG, BankXyz, BankValues;
  DeviceBuffer<__half> TableGrad, EncG;
  DeviceBuffer<uint32_t> TableMoments;
  DeviceBuffer<Fixed> FixedTableGrad, FixedMlpGrad; ///< deterministic mode only (GpuFixedPoint.cuh)
  DeviceBuffer<unsigned char> DeviceVolume;
  DeviceBuffer<Counters> StepCounters;
  PlateauSchedule Plateau{ Train.optimizer }; ///< loss-driven decay (OptimizerConfig::plateauWindow)
  GpuImportanceGrid Importance; ///< error-guided sampling (TrainConfig::importanceGrid), GPU-resident volumes only
  PinnedBuffer<Counters> HostStepCounters;
  PinnedBuffer<float> HostTargets[2];
  PinnedBuffer<float> HostXyz[2]; ///< out-of-core batches: the positions the source drew
  int HostValidCounts[2] = { 0, 0 };
  std::unique_ptr<ThreadPool> Pool;
  std::future<int64_t> NextBatch;
  SmemPlan WmmaPlan{};
  RegPlan RegKernelPlan{};
  TrainFn TrainKernel = nullptr;
  int Blocks = 1;
  int64_t Steps = 0;
};

} // namespace gpu
} // namespace nv
