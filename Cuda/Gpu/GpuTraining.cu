// NeuralVolume engine: training on the GPU. One step = sample targets (GPU-resident volume) or upload the batch
// the CPU threads sampled (host-sampled), one fused kernel (encoding forward, MLP forward on tensor cores, loss,
// MLP backward, weight gradients, encoding-gradient scatter with vector atomics) -- or, for large tables, the same
// kernel between a level-major encode pass and a level-major scatter pass (GpuLevels.cuh) --, one memory-bound
// Adam pass over the hash table (also writes the fp16 copy and zeroes the gradient) and a small Adam kernel for
// the MLP (GpuStep.cuh).
#include "Core/Config.h"
#include "Cpu/CpuSampler.h"
#include "Cpu/ThreadPool.h"
#include "GpuEngine.h"
#include "GpuStep.cuh"
#include "GpuInternal.cuh"
#include "GpuLevels.cuh"
#include "GpuTesting.h"

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

struct TrainArgs
{
  GridLayout grid;
  MlpShape shape;
  SmemPlan plan;
  const __half* table16;
  const __half* w16;
  const float* wout;
  float* gradTable;
  float* slots;
  float* gradPad;
  const float* xyz; ///< null: randomPoint(seed, step, i)
  uint64_t seed, step;
  const float* targets; ///< NaN = invalid sample
  int64_t n;
  int tiles;
  int l1;
  Counters* counters;
  const __half* encG; ///< two-pass: encodings from encodeLevelsKernel (level-major)
  float* dEncG;       ///< two-pass: dL/d(encoding) for scatterLevelsKernel (level-major, fp32)
};

template <int W, int F, bool TwoPass>
__global__ void __launch_bounds__(256) trainKernel(const __grid_constant__ TrainArgs a)
{
  extern __shared__ __align__(128) unsigned char smem[];
  const SmemPlan& p = a.plan;
  const MlpShape& s = a.shape;
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31, T = p.T, warps = p.warps;
  float* sx = reinterpret_cast<float*>(smem + p.xyz);
  float* stgt = reinterpret_cast<float*>(smem + p.tgt);
  float* sg = reinterpret_cast<float*>(smem + p.g);
  __half* enc = reinterpret_cast<__half*>(smem + p.enc);
  __half* acts = reinterpret_cast<__half*>(smem + p.acts);
  float* dEnc = reinterpret_cast<float*>(smem + p.acts); // alias: written when the activations are dead
  __half* dzBuf[2] = { reinterpret_cast<__half*>(smem + p.dz0), reinterpret_cast<__half*>(smem + p.dz1) };
  float* stage = reinterpret_cast<float*>(smem + p.stage) + warp * 256;
  const float* sw = reinterpret_cast<const float*>(smem + p.wout);
  const __half* wl[kMaxHidden];
  int ldw[kMaxHidden];
  stageWeights(s, p, smem, a.w16, a.wout, wl, ldw);
  const int pad = s.Dp - s.D;
  for (int i = threadIdx.x; i < T * pad; i += blockDim.x)
    enc[(i / pad) * p.ldE + s.D + i % pad] = __float2half(0.0f);
  __syncthreads();
  float* slot = a.slots + size_t(blockIdx.x) * s.total;
  const int row0 = warp * 16;
  const int actStride = T * p.ldA;
  bool first = true;
  float lossAcc = 0.0f;
  for (int tile = blockIdx.x; tile < a.tiles; tile += gridDim.x)
  {
    const int64_t base = int64_t(tile) * T;
    const int valid = static_cast<int>(min(int64_t(T), a.n - base));
    for (int t = threadIdx.x; t < T; t += blockDim.x)
    {
      float x[3] = { 0.0f, 0.0f, 0.0f };
      float tg = __int_as_float(0x7fc00000);
      if (t < valid)
      {
        const int64_t gi = base + t;
        if (TwoPass)
        {
          // no coordinates needed: the level-major encode and scatter passes regenerate them
        }
        else if (a.xyz)
        {
          x[0] = a.xyz[3 * gi];
          x[1] = a.xyz[3 * gi + 1];
          x[2] = a.xyz[3 * gi + 2];
        }
        else
        {
          randomPoint(a.seed, a.step, static_cast<uint64_t>(gi), x);
        }
        tg = a.targets[gi];
      }
      sx[3 * t] = x[0];
      sx[3 * t + 1] = x[1];
      sx[3 * t + 2] = x[2];
      stgt[t] = tg;
    }
    if constexpr (TwoPass)
    {
      using V = typename HalfVec<F>::T;
      const V* src = reinterpret_cast<const V*>(a.encG);
      for (int it = threadIdx.x; it < T * a.grid.levels; it += blockDim.x)
      {
        const int t = it % T, l = it / T;
        V v{};
        if (t < valid)
          v = __ldcs(src + l * a.n + base + t);
        *reinterpret_cast<V*>(enc + t * p.ldE + l * F) = v;
      }
    }
    else
    {
      __syncthreads();
      encodeTile<F>(a.grid, a.table16, sx, enc, p.ldE, T);
    }
    __syncthreads();
    // Forward: rows are private to the warp.
    forwardLayer<W>(enc, p.ldE, s.Dp, wl[0], ldw[0], acts, p.ldA, stage, row0, lane);
    for (int l = 1; l < s.H; ++l)
      forwardLayer<W>(acts + (l - 1) * actStride, p.ldA, W, wl[l], ldw[l], acts + l * actStride, p.ldA, stage, row0,
        lane);
    const __half* AH = acts + (s.H - 1) * actStride;
    {
      const int t = row0 + (lane >> 1), h = lane & 1;
      float o = 0.0f;
      const __half* r = AH + t * p.ldA + h * (W / 2);
#pragma unroll 8
      for (int i = 0; i < W / 2; ++i)
        o += __half2float(r[i]) * sw[h * (W / 2) + i];
      o += __shfl_xor_sync(0xffffffffu, o, 1);
      if (h == 0)
      {
        const float tg = stgt[t];
        float g = 0.0f;
        if (!isnan(tg))
        {
          const float diff = o - tg;
          if (a.l1)
          {
            lossAcc += fabsf(diff);
            g = diff > 0.0f ? 1.0f : (diff < 0.0f ? -1.0f : 0.0f);
          }
          else
          {
            lossAcc += diff * diff;
            g = 2.0f * diff;
          }
        }
        sg[t] = g; // unscaled: the 1/nValid factor is applied by Adam (keeps fp16 gradients in range)
      }
    }
    __syncwarp();
    for (int e = lane; e < 16 * W; e += 32)
    {
      const int t = row0 + e / W, o = e % W;
      const float av = __half2float(AH[t * p.ldA + o]);
      dzBuf[0][t * p.ldA + o] = __float2half_rn(av > 0.0f ? sg[t] * sw[o] : 0.0f);
    }
    __syncthreads();
    for (int o = threadIdx.x; o < W; o += blockDim.x)
    {
      float acc = 0.0f;
      for (int t = 0; t < T; ++t)
        acc += sg[t] * __half2float(AH[t * p.ldA + o]);
      float* d = slot + s.off[s.H] + o;
      *d = first ? acc : *d + acc;
    }
    int cur = 0;
    for (int l = s.H - 1; l >= 0; --l)
    {
      __syncthreads();
      const __half* X = l == 0 ? enc : acts + (l - 1) * actStride;
      const int ldX = l == 0 ? p.ldE : p.ldA;
      const int K = s.inDim(l);
      weightGrad<W>(dzBuf[cur], p.ldA, X, ldX, K, T, slot + s.off[l], first, warp, warps);
      if (l > 0)
        backwardInput<W>(dzBuf[cur], p.ldA, wl[l], ldw[l], K, row0, lane, stage, X, dzBuf[cur ^ 1], p.ldA, nullptr, 0);
      else
        backwardInput<W>(dzBuf[cur], p.ldA, wl[0], ldw[0], K, row0, lane, stage, nullptr, nullptr, 0, dEnc, p.ldDE);
      cur ^= 1;
    }
    __syncthreads();
    if constexpr (TwoPass)
    {
      for (int it = threadIdx.x; it < T * a.grid.levels; it += blockDim.x)
      {
        const int t = it % T, l = it / T;
        if (t < valid)
        {
          float* d = a.dEncG + (l * a.n + base + t) * F;
#pragma unroll
          for (int f = 0; f < F; ++f)
            d[f] = dEnc[t * p.ldDE + l * F + f];
        }
      }
    }
    else
    {
      scatterTile<F>(a.grid, a.gradTable, sx, dEnc, p.ldDE, T, valid);
    }
    __syncthreads();
    first = false;
  }
  for (int o = 16; o > 0; o >>= 1)
    lossAcc += __shfl_xor_sync(0xffffffffu, lossAcc, o);
  if (lane == 0 && lossAcc != 0.0f)
    atomicAdd(&a.counters->lossSum, static_cast<double>(lossAcc));
  if (!first)
  {
    __syncthreads();
    const float4* src = reinterpret_cast<const float4*>(slot);
    float4* dst = reinterpret_cast<float4*>(a.gradPad);
    for (int i = threadIdx.x; i < s.total / 4; i += blockDim.x)
      atomicAdd(dst + i, src[i]);
  }
}

using TrainFn = void (*)(TrainArgs);

/// Two-pass training (level-major encode -> MLP kernel -> level-major scatter) or the single fused kernel. Measured
/// on an H100 at batch 65536 (gpu_notes.md): two passes win when the table does not fit L2 comfortably (2^18: 0.557
/// vs 0.612 ms, 2^19: 0.754 vs 0.820) and lose on small tables (2^16: 0.388 vs 0.358, 2^14: 0.350 vs 0.322) and
/// small batches (16384 at 2^19: 0.501 vs 0.479; 32768: equal). NV_GPU_TRAIN_TWOPASS=0/1 forces a path.
bool trainTwoPass(size_t table16Bytes, int64_t batch)
{
  const char* e = std::getenv("NV_GPU_TRAIN_TWOPASS");
  if (e && *e)
    return std::atoi(e) != 0;
  return table16Bytes > (size_t(16) << 20) && batch > 32768;
}

TrainFn pickTrain(int W, int F, bool two)
{
#define NV_CASE(w, f)                                                                              \
  if (W == w && F == f)                                                                            \
    return two ? trainKernel<w, f, true> : trainKernel<w, f, false>;
  NV_CASE(16, 1) NV_CASE(16, 2) NV_CASE(16, 4) NV_CASE(16, 8)
  NV_CASE(32, 1) NV_CASE(32, 2) NV_CASE(32, 4) NV_CASE(32, 8)
  NV_CASE(64, 1) NV_CASE(64, 2) NV_CASE(64, 4) NV_CASE(64, 8)
  NV_CASE(128, 1) NV_CASE(128, 2) NV_CASE(128, 4) NV_CASE(128, 8)
#undef NV_CASE
  NV_THROW("unsupported network width / features per level on the GPU");
}

int gridFor(int64_t n, int threads = 256)
{
  const int64_t b = (n + threads - 1) / threads;
  return static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(b, int64_t(deviceInfo().sms) * 16)));
}

class GpuTrainer final : public Trainer
{
public:
  GpuTrainer(const Model& model, const VolumeView& volume, const TrainConfig& config, bool forTest)
    : Config(model.config())
    , Train(config)
    , Volume(volume)
  {
    validate(config);
    const size_t np = model.paramCount();
    NEnc = model.encodingParamCount();
    NMlp = np - NEnc;
    allocateDeviceModel(model, Dm);
    P.allocate(np, "parameters");
    G.allocate(NEnc, "hash-table gradient");
    M.allocate(np, "Adam first moments");
    V.allocate(np, "Adam second moments");
    GradPad.allocate(Dm.shape.total, "MLP gradient");
    const int64_t B = config.batchSize;
    Targets.allocate(B, "targets");
    if (trainTwoPass(Dm.table16.bytes(), B))
    {
      const int64_t D = int64_t(Dm.grid.levels) * Dm.grid.features;
      EncG.allocate(size_t(B * D), "encodings");
      DEncG.allocate(size_t(B * D), "encoding gradients");
    }
    Cnt.allocate(1, "counters");
    HCnt.allocate(1);
    Fn = pickTrain(Dm.shape.W, Dm.grid.features, EncG.get() != nullptr);
    int perSm = 0;
    Plan = choosePlan(Dm.shape, true, reinterpret_cast<const void*>(Fn), &perSm);
    const int64_t tiles = (B + Plan.T - 1) / Plan.T;
    Blocks = static_cast<int>(std::min<int64_t>(tiles, int64_t(perSm) * deviceInfo().sms));
    Slots.allocate(size_t(Blocks) * Dm.shape.total, "per-block MLP gradients");
    NV_CUDA(cudaMemcpyAsync(P.get(), model.params().data(), np * sizeof(float), cudaMemcpyHostToDevice, St.get()));
    NV_CUDA(cudaMemsetAsync(G.get(), 0, G.bytes(), St.get()));
    NV_CUDA(cudaMemsetAsync(M.get(), 0, M.bytes(), St.get()));
    NV_CUDA(cudaMemsetAsync(V.get(), 0, V.bytes(), St.get()));
    NV_CUDA(cudaMemsetAsync(GradPad.get(), 0, GradPad.bytes(), St.get()));
    packParams(P.get(), Dm, St.get());
    St.sync();

    if (forTest)
    {
      Strategy = TrainingStrategy::GpuResident;
      return;
    }
    Strategy = config.strategy;
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
      Vol.allocate(static_cast<size_t>(volume.bytes()), "source volume");
      NV_CUDA(cudaMemcpyAsync(Vol.get(), volume.data, Vol.bytes(), cudaMemcpyHostToDevice, St.get()));
      St.sync();
    }
    else
    {
      Pool.reset(new ThreadPool(config.threads));
      for (int k = 0; k < 2; ++k)
        HTargets[k].allocate(B);
      Next = std::async(std::launch::async, [this] { return prepare(1, 1); }); // step s uses buffer s % 2
    }
  }

  ~GpuTrainer() override
  {
    if (Next.valid())
    {
      try
      {
        Next.get();
      }
      catch (...)
      {
      }
    }
    cudaStreamSynchronize(St.get());
  }

  float step() override
  {
    const int64_t s = Steps + 1;
    const int64_t B = Train.batchSize;
    cudaStream_t st = St.get();
    NV_CUDA(cudaMemsetAsync(Cnt.get(), 0, sizeof(Counters), st));
    if (Strategy == TrainingStrategy::GpuResident)
    {
      launchSample(s);
    }
    else
    {
      const int k = static_cast<int>(s % 2);
      const int nValid = static_cast<int>(Next.get());
      HCounts[k] = nValid;
      NV_CUDA(cudaMemcpyAsync(&Cnt.get()->nValid, &HCounts[k], sizeof(int), cudaMemcpyHostToDevice, st));
      NV_CUDA(cudaMemcpyAsync(Targets.get(), HTargets[k].get(), B * sizeof(float), cudaMemcpyHostToDevice, st));
      // The CPU threads sample the next batch while the GPU trains on this one.
      Next = std::async(std::launch::async, [this, s] { return prepare(s + 1, static_cast<int>((s + 1) % 2)); });
    }
    launchTrain(nullptr, B, s);
    launchAdam(s);
    NV_CUDA(cudaMemcpyAsync(HCnt.get(), Cnt.get(), sizeof(Counters), cudaMemcpyDeviceToHost, st));
    St.sync();
    Steps = s;
    const Counters c = *HCnt.get();
    return c.nValid > 0 ? static_cast<float>(c.lossSum / c.nValid) : 0.0f;
  }

  int64_t stepsDone() const override { return Steps; }
  double currentLearningRate() const override { return Train.optimizer.learningRateAt(Steps + 1); }
  Device device() const override { return Device::Cuda; }

  void syncTo(Model& model) const override
  {
    NV_CHECK(model.paramCount() == NEnc + NMlp, "syncTo: model has a different configuration");
    St.sync();
    NV_CUDA(cudaMemcpy(model.params().data(), P.get(), P.bytes(), cudaMemcpyDeviceToHost));
  }

  int64_t deviceMemoryBytes() const override
  {
    return static_cast<int64_t>(Dm.bytes() + P.bytes() + G.bytes() + M.bytes() + V.bytes() + GradPad.bytes() +
      Slots.bytes() + Targets.bytes() + Vol.bytes() + Xyz.bytes() + Cnt.bytes() + EncG.bytes() + DEncG.bytes());
  }

  float lossAndGradient(const float* xyz, const float* targets, const uint8_t* valid, int64_t n,
    std::vector<float>& grad)
  {
    NV_CHECK(n >= 1 && n <= Train.batchSize, "lossAndGradient: 1..batch size samples");
    cudaStream_t st = St.get();
    Xyz.allocate(3 * n, "points");
    std::vector<float> t(n);
    int nValid = 0;
    for (int64_t i = 0; i < n; ++i)
    {
      t[i] = valid[i] ? targets[i] : std::nanf("");
      nValid += valid[i] ? 1 : 0;
    }
    Counters c{ 0.0, nValid, 0 };
    NV_CUDA(cudaMemcpyAsync(Xyz.get(), xyz, 3 * n * sizeof(float), cudaMemcpyHostToDevice, st));
    NV_CUDA(cudaMemcpyAsync(Targets.get(), t.data(), n * sizeof(float), cudaMemcpyHostToDevice, st));
    NV_CUDA(cudaMemcpyAsync(Cnt.get(), &c, sizeof(c), cudaMemcpyHostToDevice, st));
    launchTrain(Xyz.get(), n, 1);
    std::vector<float> gt(NEnc), gp(Dm.shape.total);
    NV_CUDA(cudaMemcpyAsync(gt.data(), G.get(), G.bytes(), cudaMemcpyDeviceToHost, st));
    NV_CUDA(cudaMemcpyAsync(gp.data(), GradPad.get(), GradPad.bytes(), cudaMemcpyDeviceToHost, st));
    NV_CUDA(cudaMemcpyAsync(&c, Cnt.get(), sizeof(c), cudaMemcpyDeviceToHost, st));
    NV_CUDA(cudaMemsetAsync(G.get(), 0, G.bytes(), st));
    NV_CUDA(cudaMemsetAsync(GradPad.get(), 0, GradPad.bytes(), st));
    St.sync();
    const float scale = 1.0f / static_cast<float>(std::max(nValid, 1));
    grad.assign(NEnc + NMlp, 0.0f);
    for (size_t i = 0; i < NEnc; ++i)
      grad[i] = gt[i] * scale;
    const MlpShape& s = Dm.shape;
    size_t j = NEnc;
    for (int l = 0; l < s.H; ++l)
    {
      const int K = l == 0 ? s.D : s.W;
      for (int o = 0; o < s.W; ++o)
        for (int i = 0; i < K; ++i)
          grad[j++] = gp[s.off[l] + o * s.inDim(l) + i] * scale;
    }
    for (int i = 0; i < s.W; ++i)
      grad[j++] = gp[s.off[s.H] + i] * scale;
    return nValid > 0 ? static_cast<float>(c.lossSum / nValid) : 0.0f;
  }

private:
  /// Host-sampled strategy: targets of step s into pinned buffer k (NaN = invalid); returns the valid count.
  int64_t prepare(int64_t s, int k)
  {
    const int64_t B = Train.batchSize;
    float* out = HTargets[k].get();
    std::vector<int64_t> counts(Pool->size(), 0);
    Pool->parallelFor(B, [&](int64_t b, int64_t e, int w) {
      constexpr int64_t kChunk = 1024;
      float xyz[3 * kChunk];
      uint8_t ok[kChunk];
      for (int64_t c0 = b; c0 < e; c0 += kChunk)
      {
        const int64_t m = std::min(kChunk, e - c0);
        for (int64_t i = 0; i < m; ++i)
          randomPoint(Train.seed, static_cast<uint64_t>(s), static_cast<uint64_t>(c0 + i), xyz + 3 * i);
        counts[w] += sampleTargets(Volume, xyz, m, out + c0, ok);
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

  void launchSample(int64_t s)
  {
    const int64_t B = Train.batchSize;
    const double range = Volume.valueMax - Volume.valueMin;
    const double inv = range > 0.0 ? 1.0 / range : 0.0;
    const int blocks = gridFor(B);
    const int64_t* d = Volume.dims;
    cudaStream_t st = St.get();
    switch (Volume.type)
    {
#define NV_SAMPLE(E, T)                                                                            \
  case ScalarType::E:                                                                              \
    sampleKernel<T><<<blocks, 256, 0, st>>>(reinterpret_cast<const T*>(Vol.get()), d[0], d[1], d[2],           \
      Volume.valueMin, inv, Train.seed, static_cast<uint64_t>(s), B, Targets.get(), Cnt.get());    \
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

  void launchTrain(const float* xyz, int64_t n, int64_t s)
  {
    TrainArgs a;
    a.grid = Dm.grid;
    a.shape = Dm.shape;
    a.plan = Plan;
    a.table16 = Dm.table16.get();
    a.w16 = Dm.w16.get();
    a.wout = P.get() + NEnc + (NMlp - Dm.shape.W); // fp32 output row (last MLP layer)
    a.gradTable = G.get();
    a.slots = Slots.get();
    a.gradPad = GradPad.get();
    a.xyz = xyz;
    a.seed = Train.seed;
    a.step = static_cast<uint64_t>(s);
    a.targets = Targets.get();
    a.n = n;
    const int64_t tiles = (n + Plan.T - 1) / Plan.T;
    a.tiles = static_cast<int>(tiles);
    a.l1 = Train.loss == LossType::L1 ? 1 : 0;
    a.counters = Cnt.get();
    a.encG = EncG.get();
    a.dEncG = DEncG.get();
    const int blocks = static_cast<int>(std::min<int64_t>(tiles, Blocks));
    FwdArgs f{};
    const dim3 lg(static_cast<unsigned>((n + 255) / 256), static_cast<unsigned>(Dm.grid.levels));
    if (EncG.get())
    {
      f.grid = Dm.grid;
      f.table16 = Dm.table16.get();
      f.xyz = xyz;
      f.random = xyz ? 0 : 1;
      f.seed = Train.seed;
      f.step = static_cast<uint64_t>(s);
      f.n = n;
      switch (Dm.grid.features)
      {
        case 1: encodeLevelsKernel<1><<<lg, 256, 0, St.get()>>>(f, EncG.get()); break;
        case 2: encodeLevelsKernel<2><<<lg, 256, 0, St.get()>>>(f, EncG.get()); break;
        case 4: encodeLevelsKernel<4><<<lg, 256, 0, St.get()>>>(f, EncG.get()); break;
        default: encodeLevelsKernel<8><<<lg, 256, 0, St.get()>>>(f, EncG.get()); break;
      }
      NV_CUDA_LAUNCH();
    }
    Fn<<<blocks, Plan.warps * 32, Plan.total, St.get()>>>(a);
    NV_CUDA_LAUNCH();
    if (EncG.get())
    {
      switch (Dm.grid.features)
      {
        case 1: scatterLevelsKernel<1><<<lg, 256, 0, St.get()>>>(f, DEncG.get(), G.get()); break;
        case 2: scatterLevelsKernel<2><<<lg, 256, 0, St.get()>>>(f, DEncG.get(), G.get()); break;
        case 4: scatterLevelsKernel<4><<<lg, 256, 0, St.get()>>>(f, DEncG.get(), G.get()); break;
        default: scatterLevelsKernel<8><<<lg, 256, 0, St.get()>>>(f, DEncG.get(), G.get()); break;
      }
      NV_CUDA_LAUNCH();
    }
  }

  void launchAdam(int64_t s)
  {
    const OptimizerConfig& o = Train.optimizer;
    const double bc1 = 1.0 - std::pow(o.beta1, static_cast<double>(s));
    const double bc2 = 1.0 - std::pow(o.beta2, static_cast<double>(s));
    const double lr = static_cast<float>(o.learningRateAt(s));
    AdamArgs a;
    a.b1 = static_cast<float>(o.beta1);
    a.b2 = static_cast<float>(o.beta2);
    a.a1 = 1.0f - a.b1;
    a.a2 = 1.0f - a.b2;
    a.eps = static_cast<float>(o.epsilon);
    a.stepSize = static_cast<float>(lr / bc1);
    a.invSqrtBc2 = static_cast<float>(1.0 / std::sqrt(bc2));
    cudaStream_t st = St.get();
    const int64_t n = static_cast<int64_t>(NEnc);
    const int blocks = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>((n / 4 + 255) / 256, int64_t(deviceInfo().sms) * 8)));
    adamTableKernel<<<blocks, 256, 0, st>>>(P.get(), G.get(), M.get(), V.get(), Dm.table16.get(), n, a, Cnt.get());
    NV_CUDA_LAUNCH();
    adamMlpKernel<<<gridFor(NMlp), 256, 0, st>>>(P.get() + NEnc, M.get() + NEnc, V.get() + NEnc, GradPad.get(),
      Dm.w16.get(), Dm.wout.get(), Dm.shape, static_cast<int64_t>(NMlp), a, Cnt.get());
    NV_CUDA_LAUNCH();
  }

  ModelConfig Config;
  TrainConfig Train;
  VolumeView Volume;
  TrainingStrategy Strategy = TrainingStrategy::GpuResident;
  size_t NEnc = 0, NMlp = 0;
  mutable Stream St;
  DeviceModel Dm;
  DeviceBuffer<float> P, G, M, V, GradPad, Slots, Targets, Xyz, DEncG;
  DeviceBuffer<__half> EncG;
  DeviceBuffer<unsigned char> Vol;
  DeviceBuffer<Counters> Cnt;
  PinnedBuffer<Counters> HCnt;
  PinnedBuffer<float> HTargets[2];
  int HCounts[2] = { 0, 0 };
  std::unique_ptr<ThreadPool> Pool;
  std::future<int64_t> Next;
  SmemPlan Plan{};
  TrainFn Fn = nullptr;
  int Blocks = 1;
  int64_t Steps = 0;
};

} // namespace

std::unique_ptr<Trainer> createTrainer(const Model& model, const VolumeView& volume, const TrainConfig& config)
{
  return std::unique_ptr<Trainer>(new GpuTrainer(model, volume, config, false));
}

float testLossAndGradient(const Model& model, const TrainConfig& config, const float* xyz, const float* targets,
  const uint8_t* valid, int64_t n, std::vector<float>& grad)
{
  const float dummy[8] = { 0, 0, 0, 0, 0, 0, 0, 0 };
  VolumeView v;
  v.data = dummy;
  v.dims[0] = v.dims[1] = v.dims[2] = 2;
  TrainConfig c = config;
  c.batchSize = static_cast<int>(std::max<int64_t>(n, 1));
  GpuTrainer t(model, v, c, true);
  return t.lossAndGradient(xyz, targets, valid, n, grad);
}

} // namespace gpu
} // namespace nv
