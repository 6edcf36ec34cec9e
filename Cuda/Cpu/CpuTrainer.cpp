#include "CpuTrainer.h"

#include "Core/Error.h"
#include "Core/GridQuantizer.h"
#include "Core/Model.h"
#include "CpuHashGrid.h"
#include "CpuSampler.h"
#include "HugePages.h"

#include <algorithm>
#include <cmath>

namespace nv
{

CpuTrainer::CpuTrainer(const Model& model, const VolumeView& volume, const TrainingPoints& points,
  const TrainConfig& config, PublishFn publish)
  : Config(model.config())
  , Layout(model.layout())
  , Mlp(model)
  , Train(config)
  , Volume(volume)
  , Points(points)
  , Pool(config.threads, config.lowPriority)
  , Params(model.params())
  , Grad(model.paramCount(), 0.0f)
  , TransposedWeights(Mlp.paramCount())
  , Adam(config.optimizer, model.paramCount())
  , Plateau(config.optimizer)
  , Publish(std::move(publish))
{
  NV_CHECK(Publish != nullptr, "a trainer needs the session it publishes to");
  validate(config);
  NV_CHECK(Params.size() == model.encodingParamCount() + Mlp.paramCount(), "model parameter count mismatch");
  adviseHugePages(Params); // the hash table and its gradient are read and written at random
  adviseHugePages(Grad);
  const size_t B = static_cast<size_t>(config.batchSize);
  Xyz.resize(3 * B);
  Targets.resize(B);
  Valid.resize(B);
  DEnc.resize(B * Config.encoding.outputDims());
  Work.resize(Pool.size());
  if (points.count == 0)
    Importance.reset(config.importanceGrid, Pool.size());
  const int W = Config.network.width;
  for (Scratch& s : Work)
  {
    s.enc.resize(static_cast<size_t>(kTile) * Config.encoding.outputDims());
    s.acts.resize(static_cast<size_t>(kTile) * W * Config.network.hiddenLayers);
    s.out.resize(kTile);
    s.dOut.resize(kTile);
    s.tmp.resize(2 * static_cast<size_t>(kTile) * W);
    s.dW.resize(Mlp.paramCount());
  }
}

void CpuTrainer::syncTo(Model& model) const
{
  NV_CHECK(model.paramCount() == Params.size(), "syncTo: model has a different configuration");
  model.params() = Params;
}

void CpuTrainer::publish()
{
  Publish(Params);
}

bool CpuTrainer::quantizationAware(int64_t step) const
{
  const OptimizerConfig& o = Train.optimizer;
  const double fraction = Train.quantizationAwareFraction;
  // Only where the rate anneals: at the full rate of the hold (a run no longer than holdSteps trains at it to the
  // end) the fine-tuning only moves the trajectory (a 48^3 Wavelet at 300 steps: -0.8 to +1.2 dB from size to size).
  const bool annealing = o.effectiveSchedule() != LearningRateSchedule::StepDecay && step > o.holdSteps;
  return fraction > 0.0 && o.plannedSteps > 0.0 && annealing &&
    static_cast<double>(step) > o.plannedSteps * (1.0 - fraction);
}

void CpuTrainer::quantizeForward()
{
  Stored.resize(Params.size());
  const int L = Layout.levels;
  // One level per worker: its step from its float entries (as Model::quantize chooses it), then its codes' values.
  Pool.runOnAll([&](int w) {
    for (int l = w; l < L; l += Pool.size())
    {
      const size_t first = size_t(Layout.level[l].offset) * Layout.features;
      const size_t n = size_t(Layout.level[l].entries) * Layout.features;
      const float step = GridQuantizer::chooseStep(Params.data() + first, n);
      for (size_t i = first; i < first + n; ++i)
        Stored[i] = GridQuantizer::value(GridQuantizer::code(Params[i], step), step);
    }
  });
  const size_t mlp = Layout.totalEntries * static_cast<size_t>(Layout.features);
  for (size_t i = mlp; i < Params.size(); ++i)
    Stored[i] = halfToFloat(floatToHalf(Params[i])); // the stored MLP is fp16
}

float CpuTrainer::forwardBackward(const float* params, int64_t n, int64_t nValid, bool measure)
{
  const float* table = params;
  const float* W = params + Layout.totalEntries * static_cast<size_t>(Layout.features);
  Mlp.transpose(W, TransposedWeights.data());
  const int D = Config.encoding.outputDims();
  const float scale = 1.0f / static_cast<float>(std::max<int64_t>(nValid, 1));
  const bool l1 = Train.loss == LossType::L1;

  // Encode, MLP forward and backward per tile; MLP gradients per worker, encoding gradients stored per sample.
  Pool.parallelFor(n, [&](int64_t b, int64_t e, int w) {
    Scratch& s = Work[w];
    std::fill(s.dW.begin(), s.dW.end(), 0.0f);
    s.loss = 0.0;
    for (int64_t t0 = b; t0 < e; t0 += kTile)
    {
      const int m = static_cast<int>(std::min<int64_t>(kTile, e - t0));
      CpuHashGrid::encode(Layout, table, Xyz.data() + 3 * t0, m, s.enc.data());
      Mlp.forward(TransposedWeights.data(), s.enc.data(), m, s.acts.data(), s.out.data());
      for (int k = 0; k < m; ++k)
      {
        const int64_t i = t0 + k;
        if (!Valid[i])
        {
          s.dOut[k] = 0.0f;
          continue;
        }
        const float diff = s.out[k] - Targets[i];
        if (measure)
          Importance.add(w, &Xyz[3 * i], std::fabs(diff));
        if (l1)
        {
          s.loss += std::fabs(diff);
          s.dOut[k] = diff > 0.0f ? scale : (diff < 0.0f ? -scale : 0.0f);
        }
        else
        {
          s.loss += static_cast<double>(diff) * diff;
          s.dOut[k] = 2.0f * diff * scale;
        }
      }
      Mlp.backward(W, s.enc.data(), s.acts.data(), s.dOut.data(), m, s.dW.data(), DEnc.data() + t0 * D, s.tmp.data());
    }
  });

  // Encoding backward: each level belongs to one worker and visits samples in order (no races, deterministic).
  const int L = Layout.levels;
  float* gradTable = Grad.data();
  Pool.runOnAll([&](int w) {
    for (int l = w; l < L; l += Pool.size())
    {
      CpuHashGrid::backwardLevels(Layout, Xyz.data(), n, DEnc.data(), gradTable, l, l + 1);
    }
  });

  // Reduce MLP gradients in worker order.
  float* gradMlp = Grad.data() + Layout.totalEntries * static_cast<size_t>(Layout.features);
  const int64_t nw = static_cast<int64_t>(Mlp.paramCount());
  Pool.parallelFor(nw, [&](int64_t b, int64_t e, int) {
    for (int64_t i = b; i < e; ++i)
    {
      float acc = 0.0f;
      for (const Scratch& s : Work)
        acc += s.dW[i];
      gradMlp[i] += acc;
    }
  });
  double loss = 0.0;
  for (const Scratch& s : Work)
    loss += s.loss;
  return static_cast<float>(loss * scale);
}

float CpuTrainer::step()
{
  const int64_t s = Steps + 1;
  const int64_t B = Train.batchSize;
  std::vector<int64_t> counts(Pool.size(), 0);
  if (Source)
    Source->prepareStep(static_cast<uint64_t>(s)); // blocks swapped in before the batch is drawn
  Pool.parallelFor(B, [&](int64_t b, int64_t e, int w) {
    if (Source)
    {
      counts[w] = Source->fill(Train.seed, static_cast<uint64_t>(s), b, e - b, &Xyz[3 * b], &Targets[b], &Valid[b]);
      return;
    }
    if (Points.count > 0)
    {
      // A bank of points: the batch is drawn from it (the same indices as the CUDA trainer's gather).
      int64_t valid = 0;
      for (int64_t i = b; i < e; ++i)
      {
        const int64_t k = randomBankIndex(Train.seed, static_cast<uint64_t>(s), static_cast<uint64_t>(i), Points.count);
        std::copy(Points.xyz + 3 * k, Points.xyz + 3 * k + 3, &Xyz[3 * i]);
        const float t = Points.values[k];
        const bool ok = std::isfinite(t);
        Targets[i] = ok ? t : 0.0f;
        Valid[i] = ok ? 1 : 0;
        valid += ok ? 1 : 0;
      }
      counts[w] = valid;
      return;
    }
    for (int64_t i = b; i < e; ++i)
    {
      Importance.point(Train.seed, static_cast<uint64_t>(s), static_cast<uint64_t>(i), &Xyz[3 * i]);
    }
    counts[w] = sampleTargets(Volume, Xyz.data() + 3 * b, e - b, Targets.data() + b, Valid.data() + b);
  });
  int64_t nValid = 0;
  for (int64_t c : counts)
    nValid += c;
  Steps = s;
  if (nValid == 0)
  {
    return 0.0f; // nothing valid to learn from in this batch
  }
  const bool stored = quantizationAware(s);
  if (stored)
    quantizeForward(); // forward through the stored network; the update below goes to the float parameters
  const float loss = forwardBackward(stored ? Stored.data() : Params.data(), B, nValid, Importance.enabled());
  Adam.update(Params.data(), Grad.data(), s, Pool, Plateau.scale());
  Plateau.observe(loss);
  if (Importance.enabled() && s % kImportanceInterval == 0)
    Importance.refresh(); // the errors of the last kImportanceInterval batches; used from step s + 1
  return loss;
}

float CpuTrainer::lossAndGradient(const float* xyz, const float* targets, const uint8_t* valid, int64_t n,
  std::vector<float>& grad)
{
  NV_CHECK(n <= Train.batchSize, "lossAndGradient: more samples than the batch size");
  std::copy(xyz, xyz + 3 * n, Xyz.begin());
  std::copy(targets, targets + n, Targets.begin());
  std::copy(valid, valid + n, Valid.begin());
  int64_t nValid = 0;
  for (int64_t i = 0; i < n; ++i)
    nValid += valid[i] ? 1 : 0;
  std::fill(Grad.begin(), Grad.end(), 0.0f);
  const bool stored = quantizationAware(Steps + 1); // as the next step would see the network
  if (stored)
    quantizeForward();
  const float loss = forwardBackward(stored ? Stored.data() : Params.data(), n, nValid);
  grad = Grad;
  std::fill(Grad.begin(), Grad.end(), 0.0f);
  return loss;
}

} // namespace nv
