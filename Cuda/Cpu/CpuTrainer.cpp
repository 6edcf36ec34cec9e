#include "CpuTrainer.h"

#include "Core/Error.h"
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

float CpuTrainer::forwardBackward(int64_t n, int64_t nValid, bool measure)
{
  const float* table = Params.data();
  const float* W = Params.data() + Layout.totalEntries * static_cast<size_t>(Layout.features);
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
  const float loss = forwardBackward(B, nValid, Importance.enabled());
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
  const float loss = forwardBackward(n, nValid);
  grad = Grad;
  std::fill(Grad.begin(), Grad.end(), 0.0f);
  return loss;
}

} // namespace nv
