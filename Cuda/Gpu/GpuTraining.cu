// NeuralVolume engine: training on the GPU. One step = sample the targets (GPU-resident volume) or upload the batch
// the CPU threads sampled (host-sampled); the MLP training kernel -- register-resident mma.sync (GpuTrainRegKernel.cuh)
// for widths up to 64, WMMA otherwise (GpuTrainWmma.cuh) -- which either encodes and scatters the table gradient
// itself (small tables) or sits between a level-major encode pass and a level-major scatter pass (GpuLevels.cuh);
// then one memory-bound Adam kernel for the table (fp16 gradient, 16-bit moments) and the MLP (GpuAdam.cuh).
// Deterministic mode sums the gradients in fixed point (GpuFixedPoint.cuh), so a seed gives the same bits every run.
// Trainer::steps queues many steps with one read-back of their losses.
#include "Core/Config.h"
#include "Core/PlateauSchedule.h"
#include "Cpu/CpuSampler.h"
#include "Cpu/ThreadPool.h"
#include "GpuEngine.h"
#include "GpuInternal.cuh"
#include "GpuTrainKernelChoice.cuh"
#include "GpuTrainerState.cuh"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <future>
#include <memory>
#include <vector>

namespace nv
{
namespace gpu
{
namespace
{

class GpuTrainer final : public Trainer, private GpuTrainerState
{
public:
  /// source: out-of-core batches (BatchSource.h), drawn on the host like the host-sampled strategy's, their
  /// positions copied with their targets; else volume or points.
  GpuTrainer(const Model& model, const VolumeView& volume, const TrainingPoints& points, const TrainConfig& config,
    const KernelOptions& options, PublishFn publish, BatchSource* source = nullptr)
    : GpuTrainerState(model, volume, points, config, options, std::move(publish), source)
    , Ordinal(currentDevice()) // the session's, selected by the session that creates this trainer
  {
    validate(config);
    allocateTraining(model, config, options);
    uploadParameters(model);
    prepareSampling(volume, points, config);
  }

  /// Where each step's samples come from: a bank of points, the volume on the GPU, or host-sampled batches (of the
  /// volume or of an out-of-core source), the first one prepared now.
  void prepareSampling(const VolumeView& volume, const TrainingPoints& points, const TrainConfig& config)
  {
    const int64_t B = config.batchSize;
    if (points.count > 0)
    {
      // A bank of points: uploaded once; each step gathers its batch on the GPU.
      Strategy = TrainingStrategy::GpuResident;
      BankXyz.allocate(size_t(3 * points.count), "bank of training points (positions)");
      BankValues.allocate(size_t(points.count), "bank of training points (values)");
      Xyz.allocate(size_t(3 * B), "training batch positions");
      NV_CUDA(cudaMemcpyAsync(BankXyz.get(), points.xyz, BankXyz.bytes(), cudaMemcpyHostToDevice, ComputeStream.get()));
      NV_CUDA(cudaMemcpyAsync(BankValues.get(), points.values, BankValues.bytes(), cudaMemcpyHostToDevice,
        ComputeStream.get()));
      ComputeStream.sync();
      return;
    }
    Strategy = Source ? TrainingStrategy::HostSampled : config.strategy;
    if (Strategy == TrainingStrategy::Auto)
    {
      size_t freeB = 0, totalB = 0;
      NV_CUDA(cudaMemGetInfo(&freeB, &totalB));
      // Headroom: keep 10% of the card plus 256 MiB free for the rest of the application.
      const double headroom = 0.1 * double(totalB) + 256.0 * 1048576.0;
      Strategy = double(volume.bytes()) + headroom < double(freeB) ? TrainingStrategy::GpuResident
                                                                    : TrainingStrategy::HostSampled;
    }
    if (Strategy == TrainingStrategy::GpuResident)
    {
      DeviceVolume.allocate(static_cast<size_t>(volume.bytes()), "source volume");
      NV_CUDA(cudaMemcpyAsync(DeviceVolume.get(), volume.data, DeviceVolume.bytes(), cudaMemcpyHostToDevice,
        ComputeStream.get()));
      if (config.importanceGrid > 0)
      {
        // Error-guided sampling (GpuImportance.cuh): sampleKernel writes the positions; the probes read the fp16
        // table, refreshed before each (the register-resident kernel does not keep it).
        Importance.allocate(config.importanceGrid, B, ComputeStream.get());
        Xyz.allocate(size_t(3 * B), "training batch positions");
        if (Network.table16.size() == 0)
          Network.table16.allocate(EncodingParamCount, "fp16 hash table (importance probes)");
      }
      ComputeStream.sync();
    }
    else
    {
      Pool.reset(new ThreadPool(config.threads));
      for (int k = 0; k < 2; ++k)
        HostTargets[k].allocate(B);
      if (Source)
      {
        for (int k = 0; k < 2; ++k)
          HostXyz[k].allocate(3 * B);
        Xyz.allocate(size_t(3 * B), "training batch positions");
      }
      NextBatch = std::async(std::launch::async, [this] { return prepare(1, 1); }); // step s uses buffer s % 2
    }
  }

  ~GpuTrainer() override
  {
    cudaSetDevice(Ordinal); // the buffers are released on their device (nothing may leave a destructor)
    if (NextBatch.valid())
    {
      try
      {
        NextBatch.get();
      }
      catch (...)
      {
      }
    }
    cudaStreamSynchronize(ComputeStream.get());
  }

  float step() override
  {
    float loss = 0.0f;
    steps(1, &loss);
    return loss;
  }

  /// GPU-resident: up to kSlots - 1 steps are queued at a time (each with its own counters slot, the previous
  /// step's slot left intact for the loss-gradient scale) and their losses read back once. Host-sampled: one step
  /// at a time, the CPU threads sampling the next batch while the GPU trains on this one.
  void steps(int64_t count, float* losses) override
  {
    const int64_t B = Train.batchSize;
    useDevice(Ordinal); // a background training thread starts on device 0
    cudaStream_t st = ComputeStream.get();
    for (int64_t done = 0; done < count;)
    {
      const int64_t m = Strategy == TrainingStrategy::GpuResident ? std::min<int64_t>(count - done, kSlots - 1) : 1;
      const int64_t s0 = Steps + 1;
      forSlots(s0, m, [&](Counters* d, Counters*, size_t k) { NV_CUDA(cudaMemsetAsync(d, 0, k * sizeof(Counters), st)); });
      for (int64_t s = s0; s < s0 + m; ++s)
      {
        if (Points.count > 0)
        {
          launchGather(s);
        }
        else if (Strategy == TrainingStrategy::GpuResident)
        {
          launchSample(s);
        }
        else
        {
          const int k = static_cast<int>(s % 2);
          HostValidCounts[k] = static_cast<int>(NextBatch.get());
          NV_CUDA(cudaMemcpyAsync(&slot(s)->nValid, &HostValidCounts[k], sizeof(int), cudaMemcpyHostToDevice, st));
          NV_CUDA(cudaMemcpyAsync(Targets.get(), HostTargets[k].get(), B * sizeof(float), cudaMemcpyHostToDevice, st));
          if (Source)
            NV_CUDA(cudaMemcpyAsync(Xyz.get(), HostXyz[k].get(), 3 * B * sizeof(float), cudaMemcpyHostToDevice, st));
          NextBatch =
            std::async(std::launch::async, [this, s] { return prepare(s + 1, static_cast<int>((s + 1) % 2)); });
        }
        launchTrain(Points.count > 0 || Importance.enabled() || Source ? Xyz.get() : nullptr, B, s);
        launchAdam(s);
        if (Importance.enabled() && s % kImportanceInterval == 0)
          launchImportance();
      }
      forSlots(s0, m, [&](Counters* d, Counters* h, size_t k) {
        NV_CUDA(cudaMemcpyAsync(h, d, k * sizeof(Counters), cudaMemcpyDeviceToHost, st));
      });
      ComputeStream.sync();
      for (int64_t s = s0; s < s0 + m; ++s)
      {
        const Counters& c = HostStepCounters.get()[s % kSlots];
        const float loss = c.nValid > 0 ? static_cast<float>(c.lossSum / c.nValid) : 0.0f;
        if (losses)
          losses[done + (s - s0)] = loss;
        Plateau.observe(loss); // the rate of the next queue of steps (queued steps share their queue's rate)
      }
      Steps += m;
      done += m;
    }
  }

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
    Train.optimizer.plannedSteps = steps; // the rate of each queued step is computed at its launch
  }
  Device device() const override { return Device::Cuda; }

  void syncTo(Model& model) const override
  {
    NV_CHECK(model.paramCount() == EncodingParamCount + MlpParamCount, "syncTo: model has a different configuration");
    useDevice(Ordinal);
    ComputeStream.sync();
    NV_CUDA(cudaMemcpy(model.params().data(), Params.get(), Params.bytes(), cudaMemcpyDeviceToHost));
  }

  /// The session packs the fp32 parameters into its own fp16 copy, on this trainer's stream, and waits for it.
  void publish() override
  {
    NV_CHECK(Publish != nullptr, "this trainer has no session to publish to");
    useDevice(Ordinal);
    Publish(Params.get(), ComputeStream.get());
  }

  int64_t deviceMemoryBytes() const override
  {
    return static_cast<int64_t>(Network.bytes() + Params.bytes() + TableGrad.bytes() + TableMoments.bytes() +
      MlpFirstMoment.bytes() + MlpSecondMoment.bytes() + GradPad.bytes() + Slots.bytes() + Targets.bytes() +
      DeviceVolume.bytes() + Xyz.bytes() + BankXyz.bytes() + BankValues.bytes() + StepCounters.bytes() + EncG.bytes() +
      DEncG.bytes() + FixedTableGrad.bytes() + FixedMlpGrad.bytes() + Importance.bytes());
  }

  float lossAndGradient(const float* xyz, const float* targets, const uint8_t* valid, int64_t n,
    std::vector<float>& grad) override
  {
    NV_CHECK(n >= 1 && n <= Train.batchSize, "lossAndGradient: 1..batch size samples");
    useDevice(Ordinal);
    if (NextBatch.valid())
      NextBatch.wait(); // host-sampled: the next batch's preparation does not touch the buffers used here
    cudaStream_t st = ComputeStream.get();
    ComputeStream.sync();
    DeviceBuffer<float> points;
    points.allocate(size_t(3 * n), "points");
    std::vector<float> t(n);
    int nValid = 0;
    for (int64_t i = 0; i < n; ++i)
    {
      t[i] = valid[i] ? targets[i] : std::nanf("");
      nValid += valid[i] ? 1 : 0;
    }
    Counters c{};
    c.nValid = nValid;
    NV_CUDA(cudaMemcpyAsync(points.get(), xyz, 3 * n * sizeof(float), cudaMemcpyHostToDevice, st));
    NV_CUDA(cudaMemcpyAsync(Targets.get(), t.data(), n * sizeof(float), cudaMemcpyHostToDevice, st));
    NV_CUDA(cudaMemcpyAsync(slot(1), &c, sizeof(c), cudaMemcpyHostToDevice, st));
    launchTrain(points.get(), n, 1);
    std::vector<__half> gt(EncodingParamCount);
    std::vector<float> gp(Network.shape.total);
    NV_CUDA(cudaMemcpyAsync(gt.data(), TableGrad.get(), TableGrad.bytes(), cudaMemcpyDeviceToHost, st));
    NV_CUDA(cudaMemcpyAsync(gp.data(), GradPad.get(), GradPad.bytes(), cudaMemcpyDeviceToHost, st));
    NV_CUDA(cudaMemcpyAsync(&c, slot(1), sizeof(c), cudaMemcpyDeviceToHost, st));
    NV_CUDA(cudaMemsetAsync(TableGrad.get(), 0, TableGrad.bytes(), st));
    NV_CUDA(cudaMemsetAsync(GradPad.get(), 0, GradPad.bytes(), st));
    ComputeStream.sync();
    const float scale = 1.0f / static_cast<float>(std::max(nValid, 1));
    grad.assign(EncodingParamCount + MlpParamCount, 0.0f);
    for (size_t i = 0; i < EncodingParamCount; ++i)
      grad[i] = __half2float(gt[i]) * scale;
    const MlpShape& s = Network.shape;
    size_t j = EncodingParamCount;
    for (int l = 0; l < s.hiddenLayers; ++l)
    {
      const int K = l == 0 ? s.inputs : s.width;
      for (int o = 0; o < s.width; ++o)
        for (int i = 0; i < K; ++i)
          grad[j++] = gp[s.off[l] + o * s.inDim(l) + i] * scale;
    }
    for (int i = 0; i < s.width; ++i)
      grad[j++] = gp[s.off[s.hiddenLayers] + i] * scale;
    return nValid > 0 ? static_cast<float>(c.lossSum / nValid) : 0.0f;
  }

private:
  const int Ordinal; ///< the CUDA device of the session and of every buffer here

  /// Host-sampled strategy: targets of step s into pinned buffer k (NaN = invalid); returns the valid count.
  int64_t prepare(int64_t s, int k)
  {
    const int64_t B = Train.batchSize;
    float* out = HostTargets[k].get();
    std::vector<int64_t> counts(Pool->size(), 0);
    if (Source)
      Source->prepareStep(static_cast<uint64_t>(s)); // blocks swapped in before the batch is drawn
    Pool->parallelFor(B, [&](int64_t b, int64_t e, int w) {
      constexpr int64_t kChunk = 1024;
      float xyz[3 * kChunk];
      uint8_t ok[kChunk];
      for (int64_t c0 = b; c0 < e; c0 += kChunk)
      {
        const int64_t m = std::min(kChunk, e - c0);
        if (Source)
          counts[w] +=
            Source->fill(Train.seed, static_cast<uint64_t>(s), c0, m, HostXyz[k].get() + 3 * c0, out + c0, ok);
        else
        {
          for (int64_t i = 0; i < m; ++i)
            randomPoint(Train.seed, static_cast<uint64_t>(s), static_cast<uint64_t>(c0 + i), xyz + 3 * i);
          counts[w] += sampleTargets(Volume, xyz, m, out + c0, ok);
        }
        for (int64_t i = 0; i < m; ++i)
          if (!ok[i])
            out[c0 + i] = std::nanf("");
      }
    });
    int64_t total = 0;
    for (int64_t c : counts)
      total += c;
    return total;
  }

  void launchGather(int64_t s)
  {
    const int64_t B = Train.batchSize;
    gatherKernel<<<gridFor(B), 256, 0, ComputeStream.get()>>>(BankXyz.get(), BankValues.get(), Points.count, Train.seed,
      static_cast<uint64_t>(s), B, Xyz.get(), Targets.get(), slot(s));
    NV_CUDA_LAUNCH();
  }

  void launchSample(int64_t s)
  {
    const int64_t B = Train.batchSize;
    const ValueRange range(Volume.valueMin, Volume.valueMax); // (v - min) / (max - min), safe when max - min overflows
    const int blocks = gridFor(B);
    const int64_t* d = Volume.dims;
    cudaStream_t st = ComputeStream.get();
    const ImportanceDraw draw{ Importance.enabled() ? Importance.cdf.get() : nullptr, Importance.cells,
      Importance.invCells, Xyz.get() };
    switch (Volume.type)
    {
#define NV_SAMPLE(E, T)                                                                            \
  case ScalarType::E:                                                                              \
    sampleKernel<T><<<blocks, 256, 0, st>>>(reinterpret_cast<const T*>(DeviceVolume.get()), d[0], d[1], d[2], \
      range, Train.seed, static_cast<uint64_t>(s), B, Targets.get(), slot(s), draw);\
    break;
      NV_SAMPLE(Int8, int8_t)
      NV_SAMPLE(UInt8, uint8_t)
      NV_SAMPLE(Int16, int16_t)
      NV_SAMPLE(UInt16, uint16_t)
      NV_SAMPLE(Int32, int32_t)
      NV_SAMPLE(UInt32, uint32_t)
      NV_SAMPLE(Int64, int64_t)
      NV_SAMPLE(UInt64, uint64_t)
      NV_SAMPLE(Float32, float)
      NV_SAMPLE(Float64, double)
#undef NV_SAMPLE
    }
    NV_CUDA_LAUNCH();
  }

  /// Importance grid: the network (after this step's update) at the step's points, per-cell errors, new CDF.
  void launchImportance()
  {
    const int64_t B = Train.batchSize;
    cudaStream_t st = ComputeStream.get();
    if (RegKernelPlan.warps > 0)
      packParams(Params.get(), Network, st); // the fp16 table the forward kernel reads
    launchForward(Network, Xyz.get(), 0, 0, 0, 0, 0, B, Importance.out.get(), st);
    importanceMeasureKernel<<<gridFor(B), 256, 0, st>>>(Xyz.get(), Importance.out.get(), Targets.get(), B,
      Importance.cells, Importance.sums.get(), Importance.counts.get());
    NV_CUDA_LAUNCH();
    importanceRefreshKernel<<<1, kRefreshThreads, 0, st>>>(Importance.weights.get(), Importance.sums.get(),
      Importance.counts.get(), Importance.cdf.get(), static_cast<int>(Importance.weights.size()));
    NV_CUDA_LAUNCH();
  }

  AdamArgs adamArgs(int64_t s) const { return makeAdamArgs(Train, Plateau.scale(), s); }

  /// Forward/backward of step s on n samples (xyz null: random points). Two-pass mode: level-major encode, MLP
  /// kernel, level-major scatter of the table gradient.
  void launchTrain(const float* xyz, int64_t n, int64_t s)
  {
    cudaStream_t st = ComputeStream.get();
    TrainArgs a = trainArgs(xyz, n, s);
    int blocks = Blocks, threads = 0, smem = 0;
    if (RegKernelPlan.warps > 0)
    {
      const int64_t rows = 16 * RegKernelPlan.warps;
      blocks = static_cast<int>(std::min<int64_t>((n + rows - 1) / rows, Blocks));
      threads = RegKernelPlan.warps * 32;
      smem = RegKernelPlan.total;
    }
    else
    {
      const int64_t tiles = (n + WmmaPlan.tileSamples - 1) / WmmaPlan.tileSamples;
      a.tiles = static_cast<int>(tiles);
      blocks = static_cast<int>(std::min<int64_t>(tiles, Blocks));
      threads = WmmaPlan.warps * 32;
      smem = WmmaPlan.total;
    }
    FwdArgs f{};
    f.grid = Network.grid;
    f.table16 = Network.table16.get();
    f.table32 = RegKernelPlan.warps > 0 ? Params.get() : nullptr;
    f.xyz = xyz;
    f.random = xyz ? 0 : 1;
    f.seed = Train.seed;
    f.step = static_cast<uint64_t>(s);
    f.sampleCount = n;
    if (EncG.get())
    {
      const dim3 lg(static_cast<unsigned>((n + 255) / 256), static_cast<unsigned>(Network.grid.levels));
      const bool fp32 = f.table32 != nullptr;
      switch (Network.grid.features)
      {
        case 1: (fp32 ? encodeLevelsKernel<1, float> : encodeLevelsKernel<1>)<<<lg, 256, 0, st>>>(f, EncG.get()); break;
        case 2: (fp32 ? encodeLevelsKernel<2, float> : encodeLevelsKernel<2>)<<<lg, 256, 0, st>>>(f, EncG.get()); break;
        case 4: (fp32 ? encodeLevelsKernel<4, float> : encodeLevelsKernel<4>)<<<lg, 256, 0, st>>>(f, EncG.get()); break;
        default: (fp32 ? encodeLevelsKernel<8, float> : encodeLevelsKernel<8>)<<<lg, 256, 0, st>>>(f, EncG.get()); break;
      }
      NV_CUDA_LAUNCH();
    }
    TrainKernel<<<blocks, threads, smem, st>>>(a);
    NV_CUDA_LAUNCH();
    if (EncG.get())
    {
      const dim3 lg(static_cast<unsigned>((n + 255) / 256), static_cast<unsigned>(Network.grid.levels));
      if (FixedTableGrad.get())
        launchScatter(lg, f, FixedTableGrad.get());
      else
        launchScatter(lg, f, TableGrad.get());
    }
    if (FixedTableGrad.get())
    {
      fixedGradientKernel<<<gridFor(int64_t(EncodingParamCount)), 256, 0, st>>>(FixedTableGrad.get(), TableGrad.get(),
        int64_t(EncodingParamCount), FixedMlpGrad.get(), GradPad.get(), int64_t(Network.shape.total), slot(s));
      NV_CUDA_LAUNCH();
    }
  }

  /// Two-pass mode, pass 3: the level-major scatter of the table gradient into grad (fp16, or fixed point).
  template <typename Grad>
  void launchScatter(dim3 lg, const FwdArgs& f, Grad* grad)
  {
    cudaStream_t st = ComputeStream.get();
    switch (Network.grid.features)
    {
      case 1: scatterLevelsKernel<1, Grad><<<lg, 256, 0, st>>>(f, DEncG.get(), grad); break;
      case 2: scatterLevelsKernel<2, Grad><<<lg, 256, 0, st>>>(f, DEncG.get(), grad); break;
      case 4: scatterLevelsKernel<4, Grad><<<lg, 256, 0, st>>>(f, DEncG.get(), grad); break;
      default: scatterLevelsKernel<8, Grad><<<lg, 256, 0, st>>>(f, DEncG.get(), grad); break;
    }
    NV_CUDA_LAUNCH();
  }

  /// Adam over the hash table and the MLP, one kernel.
  void launchAdam(int64_t s)
  {
    const AdamArgs a = adamArgs(s);
    const int64_t n = static_cast<int64_t>(EncodingParamCount);
    MlpAdam q;
    q.params = Params.get() + EncodingParamCount;
    q.firstMoment = MlpFirstMoment.get();
    q.secondMoment = MlpSecondMoment.get();
    q.gradPad = GradPad.get();
    q.w16 = Network.w16.get();
    q.wout = Network.wout.get();
    q.shape = Network.shape;
    q.count = static_cast<int64_t>(MlpParamCount);
    const int64_t work = std::max<int64_t>(n / 4, q.count);
    const int blocks = static_cast<int>(
      std::max<int64_t>(1, std::min<int64_t>((work + 255) / 256, int64_t(deviceInfo().sms) * 8)));
    __half* p16 = RegKernelPlan.warps > 0 ? nullptr : Network.table16.get(); // importance probes refresh their own copy
    adamKernel<<<blocks, 256, 0, ComputeStream.get()>>>(Params.get(), TableGrad.get(), TableMoments.get(), p16, n, q, a,
      slot(s));
    NV_CUDA_LAUNCH();
  }


  /// f(device, host, count) for the ring slots of steps [s0, s0 + m) (two calls when they wrap).
  template <typename TrainKernel>
  void forSlots(int64_t s0, int64_t m, TrainKernel f)
  {
    const int64_t a = s0 % kSlots, first = std::min(m, kSlots - a);
    f(StepCounters.get() + a, HostStepCounters.get() + a, static_cast<size_t>(first));
    if (m > first)
      f(StepCounters.get(), HostStepCounters.get(), static_cast<size_t>(m - first));
  }

};

} // namespace

std::unique_ptr<Trainer> createTrainer(const Model& model, const VolumeView& volume, const TrainConfig& config,
  const KernelOptions& options, PublishFn publish)
{
  return std::unique_ptr<Trainer>(
    new GpuTrainer(model, volume, TrainingPoints(), config, options, std::move(publish)));
}

std::unique_ptr<Trainer> createTrainer(const Model& model, const TrainingPoints& points, const TrainConfig& config,
  const KernelOptions& options, PublishFn publish)
{
  return std::unique_ptr<Trainer>(
    new GpuTrainer(model, VolumeView(), points, config, options, std::move(publish)));
}

std::unique_ptr<Trainer> createTrainer(const Model& model, BatchSource& source, const TrainConfig& config,
  const KernelOptions& options, PublishFn publish)
{
  return std::unique_ptr<Trainer>(
    new GpuTrainer(model, VolumeView(), TrainingPoints(), config, options, std::move(publish), &source));
}

} // namespace gpu
} // namespace nv
