#include "CpuMlp.h"

#include "Core/Model.h"

#include <algorithm>
#include <cstring>

namespace nv
{
namespace
{

// out[t][:] = act(sum_i in[t][i] * WT[i][:]) for a layer of W outputs.
template <int W>
void layerForward(const float* in, int inDim, int n, const float* WT, float* out)
{
  for (int t = 0; t < n; ++t)
  {
    float acc[W] = {};
    const float* x = in + static_cast<size_t>(t) * inDim;
    for (int i = 0; i < inDim; ++i)
    {
      const float a = x[i];
      if (a == 0.0f)
      {
        continue;
      }
      const float* w = WT + static_cast<size_t>(i) * W;
      for (int o = 0; o < W; ++o)
      {
        acc[o] += a * w[o];
      }
    }
    float* y = out + static_cast<size_t>(t) * W;
    for (int o = 0; o < W; ++o)
    {
      y[o] = acc[o] > 0.0f ? acc[o] : 0.0f;
    }
  }
}

// dW[o][i] += sum_t dZ[t][o] * X[t][i]; blocks of 16 inputs stay in registers across the samples.
template <int W>
void weightGrad(const float* dZ, const float* X, int inDim, int n, float* dW)
{
  for (int o = 0; o < W; ++o)
  {
    float* row = dW + static_cast<size_t>(o) * inDim;
    int ib = 0;
    for (; ib + 16 <= inDim; ib += 16)
    {
      float acc[16];
      for (int k = 0; k < 16; ++k)
        acc[k] = row[ib + k];
      for (int t = 0; t < n; ++t)
      {
        const float z = dZ[static_cast<size_t>(t) * W + o];
        if (z == 0.0f)
          continue;
        const float* x = X + static_cast<size_t>(t) * inDim + ib;
        for (int k = 0; k < 16; ++k)
          acc[k] += z * x[k];
      }
      for (int k = 0; k < 16; ++k)
        row[ib + k] = acc[k];
    }
    for (; ib < inDim; ++ib)
    {
      float acc = row[ib];
      for (int t = 0; t < n; ++t)
        acc += dZ[static_cast<size_t>(t) * W + o] * X[static_cast<size_t>(t) * inDim + ib];
      row[ib] = acc;
    }
  }
}

// dX[t][:] = sum_o dZ[t][o] * Wl[o][:]   (Wl row-major [W][inDim]); mask by (mask[t][:] > 0) if mask.
template <int W>
void inputGrad(const float* dZ, const float* Wl, int inDim, int n, const float* mask, float* dX)
{
  if (inDim == W)
  {
    for (int t = 0; t < n; ++t)
    {
      float acc[W] = {};
      const float* z = dZ + static_cast<size_t>(t) * W;
      for (int o = 0; o < W; ++o)
      {
        const float zo = z[o];
        if (zo == 0.0f)
          continue;
        const float* w = Wl + static_cast<size_t>(o) * W;
        for (int i = 0; i < W; ++i)
          acc[i] += zo * w[i];
      }
      float* d = dX + static_cast<size_t>(t) * W;
      if (mask)
      {
        const float* m = mask + static_cast<size_t>(t) * W;
        for (int i = 0; i < W; ++i)
          d[i] = m[i] > 0.0f ? acc[i] : 0.0f;
      }
      else
      {
        for (int i = 0; i < W; ++i)
          d[i] = acc[i];
      }
    }
    return;
  }
  for (int t = 0; t < n; ++t)
  {
    float* d = dX + static_cast<size_t>(t) * inDim;
    std::fill(d, d + inDim, 0.0f);
    const float* z = dZ + static_cast<size_t>(t) * W;
    for (int o = 0; o < W; ++o)
    {
      const float zo = z[o];
      if (zo == 0.0f)
        continue;
      const float* w = Wl + static_cast<size_t>(o) * inDim;
      for (int i = 0; i < inDim; ++i)
        d[i] += zo * w[i];
    }
    if (mask)
    {
      const float* m = mask + static_cast<size_t>(t) * inDim;
      for (int i = 0; i < inDim; ++i)
        d[i] = m[i] > 0.0f ? d[i] : 0.0f;
    }
  }
}

template <int W>
void forwardT(const CpuMlp& m, const float* WT, const float* in, int n, float* acts, float* out)
{
  const size_t actStride = static_cast<size_t>(n) * W;
  for (int l = 0; l < m.hidden(); ++l)
  {
    const float* x = l == 0 ? in : acts + (l - 1) * actStride;
    layerForward<W>(x, m.layerIn(l), n, WT + (m.layerOffset(l) - m.layerOffset(0)), acts + l * actStride);
  }
  const float* wOut = WT + (m.layerOffset(m.hidden()) - m.layerOffset(0)); // [W][1] == [1][W]
  const float* h = acts + (m.hidden() - 1) * actStride;
  for (int t = 0; t < n; ++t)
  {
    float acc = 0.0f;
    const float* x = h + static_cast<size_t>(t) * W;
    for (int i = 0; i < W; ++i)
      acc += x[i] * wOut[i];
    out[t] = acc;
  }
}

template <int W>
void backwardT(const CpuMlp& m, const float* Wts, const float* in, const float* acts, const float* dOut, int n,
  float* dW, float* dIn, float* scratch)
{
  const size_t actStride = static_cast<size_t>(n) * W;
  const size_t base = m.layerOffset(0);
  const int H = m.hidden();
  float* dZ = scratch;
  float* dZNext = scratch + actStride;
  // Output layer (linear, 1 output).
  const float* wOut = Wts + (m.layerOffset(H) - base);
  float* gOut = dW + (m.layerOffset(H) - base);
  const float* hLast = acts + (H - 1) * actStride;
  for (int t = 0; t < n; ++t)
  {
    const float g = dOut[t];
    const float* h = hLast + static_cast<size_t>(t) * W;
    float* z = dZ + static_cast<size_t>(t) * W;
    for (int o = 0; o < W; ++o)
    {
      gOut[o] += g * h[o];
      z[o] = h[o] > 0.0f ? g * wOut[o] : 0.0f;
    }
  }
  for (int l = H - 1; l >= 0; --l)
  {
    const int inDim = m.layerIn(l);
    const float* X = l == 0 ? in : acts + (l - 1) * actStride;
    const float* Wl = Wts + (m.layerOffset(l) - base);
    weightGrad<W>(dZ, X, inDim, n, dW + (m.layerOffset(l) - base));
    if (l > 0)
    {
      inputGrad<W>(dZ, Wl, inDim, n, X, dZNext);
      std::swap(dZ, dZNext);
    }
    else if (dIn)
    {
      inputGrad<W>(dZ, Wl, inDim, n, nullptr, dIn);
    }
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
  switch (Width)
  {
    case 16:
      return forwardT<16>(*this, WT, in, n, acts, out);
    case 32:
      return forwardT<32>(*this, WT, in, n, acts, out);
    case 64:
      return forwardT<64>(*this, WT, in, n, acts, out);
    default:
      return forwardT<128>(*this, WT, in, n, acts, out);
  }
}

void CpuMlp::backward(const float* W, const float* in, const float* acts, const float* dOut, int n, float* dW,
  float* dIn, float* scratch) const
{
  switch (Width)
  {
    case 16:
      return backwardT<16>(*this, W, in, acts, dOut, n, dW, dIn, scratch);
    case 32:
      return backwardT<32>(*this, W, in, acts, dOut, n, dW, dIn, scratch);
    case 64:
      return backwardT<64>(*this, W, in, acts, dOut, n, dW, dIn, scratch);
    default:
      return backwardT<128>(*this, W, in, acts, dOut, n, dW, dIn, scratch);
  }
}

} // namespace nv
