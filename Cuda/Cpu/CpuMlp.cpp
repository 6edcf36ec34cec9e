#include "CpuMlp.h"

#include "Core/Model.h"

#include "CpuGemm.h"

#include <algorithm>
#include <cstring>

namespace nv
{
namespace
{

using gemm::Epilogue;
using gemm::Operands;
using gemm::Vec;
using gemm::kVW;

// out[t] = sum_i h[t][i] * w[i]: partial sums per vector lane, then the lanes in order.
void outputLayer(const float* h, int W, int n, const float* w, float* out)
{
  if (W % kVW != 0)
  {
    for (int t = 0; t < n; ++t)
    {
      float acc = 0.0f;
      for (int i = 0; i < W; ++i)
        acc += h[static_cast<size_t>(t) * W + i] * w[i];
      out[t] = acc;
    }
    return;
  }
  for (int t = 0; t < n; ++t)
  {
    const float* x = h + static_cast<size_t>(t) * W;
    Vec acc = gemm::load(x) * gemm::load(w);
    for (int i = kVW; i < W; i += kVW)
      acc += gemm::load(x + i) * gemm::load(w + i);
    float sum = acc[0];
    for (int k = 1; k < kVW; ++k)
      sum += acc[k];
    out[t] = sum;
  }
}

// Output layer backward: gOut[o] += sum_t g[t] h[t][o] (in t order); dZ[t][o] = h[t][o] > 0 ? g[t] w[o] : 0.
void outputBackward(const float* h, int W, int n, const float* g, const float* w, float* gOut, float* dZ)
{
  int o = 0;
  for (; o + kVW <= W; o += kVW)
  {
    Vec acc = gemm::load(gOut + o);
    const Vec wv = gemm::load(w + o);
    for (int t = 0; t < n; ++t)
    {
      const Vec hv = gemm::load(h + static_cast<size_t>(t) * W + o);
      const Vec gv = gemm::splat(g[t]);
      acc += gv * hv;
      gemm::store(dZ + static_cast<size_t>(t) * W + o, hv > Vec{} ? gv * wv : Vec{});
    }
    gemm::store(gOut + o, acc);
  }
  for (; o < W; ++o)
  {
    float acc = gOut[o];
    for (int t = 0; t < n; ++t)
    {
      const float hv = h[static_cast<size_t>(t) * W + o];
      acc += g[t] * hv;
      dZ[static_cast<size_t>(t) * W + o] = hv > 0.0f ? g[t] * w[o] : 0.0f;
    }
    gOut[o] = acc;
  }
}

} // namespace

CpuMlp::CpuMlp(int inputs, int width, int hidden)
  : Inputs(inputs)
  , Width(width)
  , Hidden(hidden)
{
}

CpuMlp::CpuMlp(const Model& model)
  : CpuMlp(model.config().encoding.outputDims(), model.config().network.width, model.config().network.hiddenLayers)
{
}

size_t CpuMlp::paramCount() const
{
  return layerOffset(Hidden + 1);
}

size_t CpuMlp::layerOffset(int l) const
{
  size_t off = 0;
  for (int k = 0; k < l; ++k)
    off += static_cast<size_t>(layerIn(k)) * layerOut(k);
  return off;
}

void CpuMlp::transpose(const float* W, float* WT) const
{
  for (int l = 0; l <= Hidden; ++l)
  {
    const int in = layerIn(l), out = layerOut(l);
    const float* a = W + layerOffset(l);
    float* b = WT + layerOffset(l);
    for (int o = 0; o < out; ++o)
      for (int i = 0; i < in; ++i)
        b[static_cast<size_t>(i) * out + o] = a[static_cast<size_t>(o) * in + i];
  }
}

void CpuMlp::forward(const float* WT, const float* in, int n, float* acts, float* out) const
{
  const size_t actStride = static_cast<size_t>(n) * Width;
  const size_t base = layerOffset(0);
  for (int l = 0; l < Hidden; ++l)
  {
    const int inDim = layerIn(l);
    Operands o{};
    o.lhs = l == 0 ? in : acts + (l - 1) * actStride;
    o.ars = inDim;
    o.aks = 1;
    o.rhs = WT + (layerOffset(l) - base); // [in][out]
    o.ldb = Width;
    o.result = acts + l * actStride;
    o.ldc = Width;
    o.innerDim = inDim;
    gemm::multiply<Epilogue::Relu>(o, n, Width);
  }
  // The output layer's [1][W] block is also its transpose.
  outputLayer(acts + (Hidden - 1) * actStride, Width, n, WT + (layerOffset(Hidden) - base), out);
}

void CpuMlp::backward(const float* W, const float* in, const float* acts, const float* dOut, int n, float* dW,
  float* dIn, float* scratch) const
{
  const size_t actStride = static_cast<size_t>(n) * Width;
  const size_t base = layerOffset(0);
  float* dZ = scratch;
  float* dZNext = scratch + actStride;
  outputBackward(acts + (Hidden - 1) * actStride, Width, n, dOut, W + (layerOffset(Hidden) - base),
    dW + (layerOffset(Hidden) - base), dZ);
  for (int l = Hidden - 1; l >= 0; --l)
  {
    const int inDim = layerIn(l);
    const float* X = l == 0 ? in : acts + (l - 1) * actStride;
    // dW_l[o][i] += sum_t dZ[t][o] X[t][i]
    Operands g{};
    g.lhs = dZ;
    g.ars = 1;
    g.aks = Width;
    g.rhs = X;
    g.ldb = inDim;
    g.result = dW + (layerOffset(l) - base);
    g.ldc = inDim;
    g.innerDim = n;
    gemm::multiply<Epilogue::Accumulate>(g, Width, inDim);
    if (l == 0 && !dIn)
    {
      break;
    }
    // dX[t][i] = sum_o dZ[t][o] W_l[o][i], masked by the ReLU of the layer below (its output X > 0).
    Operands d{};
    d.lhs = dZ;
    d.ars = Width;
    d.aks = 1;
    d.rhs = W + (layerOffset(l) - base);
    d.ldb = inDim;
    d.result = l > 0 ? dZNext : dIn;
    d.ldc = inDim;
    d.mask = X;
    d.innerDim = Width;
    if (l > 0)
    {
      gemm::multiply<Epilogue::Mask>(d, n, inDim);
      std::swap(dZ, dZNext);
    }
    else
    {
      gemm::multiply<Epilogue::Store>(d, n, inDim);
    }
  }
}

} // namespace nv
