#include "CpuHalfNetwork.h"

#include "CpuHashGrid.h"

#include "Core/Error.h"
#include "Core/Model.h"

#include <type_traits>

namespace nv
{

void CpuHalfTable::update(const Model& model, uint64_t version)
{
  const float* src = model.params().data();
  if (version == Version && src == Source)
    return;
  Version = version;
  Source = src;
  const size_t n = model.encodingParamCount();
  Rounded.resize(n);
  bool exact = true;
  for (size_t i = 0; i < n; ++i)
  {
    Rounded[i] = roundHalf(src[i]);
    exact = exact && Rounded[i] == src[i];
  }
  if (exact)
  {
    Rounded.clear();
    Rounded.shrink_to_fit();
    Table = src;
  }
  else
    Table = Rounded.data();
}

CpuHalfNetwork::CpuHalfNetwork(const Model& model, const float* table16)
  : Layout(model.layout())
  , Table(table16)
  , Inputs(model.config().encoding.outputDims())
  , Width(model.config().network.width)
  , Hidden(model.config().network.hiddenLayers)
{
  NV_CHECK(model.paramCount() == model.encodingParamCount() + model.mlpParamCount(), "the model has no parameters");
  size_t n = 0;
  for (int l = 0; l < Hidden; ++l)
    n += static_cast<size_t>(model.layerInputs(l)) * Width;
  Hidden16.resize(n);
  size_t off = 0;
  for (int l = 0; l < Hidden; ++l)
  {
    const int in = model.layerInputs(l);
    const float* w = model.params().data() + model.layerOffset(l); // [out][in]
    for (int i = 0; i < in; ++i)
      for (int o = 0; o < Width; ++o)
        Hidden16[off + static_cast<size_t>(i) * Width + o] = roundHalf(w[static_cast<size_t>(o) * in + i]);
    off += static_cast<size_t>(in) * Width;
  }
  const float* wo = model.params().data() + model.layerOffset(Hidden);
  Output.assign(wo, wo + Width);

  const int F = Layout.features;
  auto pick = [&](auto w) {
    constexpr int W = decltype(w)::value;
    switch (F)
    {
      case 1:
        Kernel = &evaluateT<W, 1>;
        break;
      case 2:
        Kernel = &evaluateT<W, 2>;
        break;
      case 4:
        Kernel = &evaluateT<W, 4>;
        break;
      default:
        Kernel = &evaluateT<W, 8>;
        break;
    }
  };
  switch (Width)
  {
    case 16:
      pick(std::integral_constant<int, 16>());
      break;
    case 32:
      pick(std::integral_constant<int, 32>());
      break;
    case 64:
      pick(std::integral_constant<int, 64>());
      break;
    default:
      NV_CHECK(Width == 128, "network width must be 16, 32, 64 or 128");
      pick(std::integral_constant<int, 128>());
      break;
  }
}

void CpuHalfNetwork::evaluate(const float* xyz, int n, float* out) const
{
  Kernel(*this, xyz, n, out);
}

template <int W, int F>
void CpuHalfNetwork::evaluateT(const CpuHalfNetwork& net, const float* xyz, int n, float* out)
{
  const GridLayout& g = net.Layout;
  const int L = g.levels;
  float enc[kMaxLevels * kMaxFeatures];
  float h[2][W];
  for (int s = 0; s < n; ++s)
  {
    // fp32 interpolation of the fp16-valued table (the CPU encoder), then fp16 encoding operands.
    CpuHashGrid::encode(g, net.Table, xyz + 3 * s, 1, enc);
    roundHalfArray(enc, L * F);
    const float* in = enc;
    int inDim = L * F;
    const float* Wt = net.Hidden16.data();
    for (int l = 0; l < net.Hidden; ++l)
    {
      float acc[W] = {};
      for (int i = 0; i < inDim; ++i)
      {
        const float a = in[i];
        if (a == 0.0f)
          continue;
        const float* w = Wt + static_cast<size_t>(i) * W;
        for (int o = 0; o < W; ++o)
          acc[o] += a * w[o];
      }
      float* y = h[l & 1];
      for (int o = 0; o < W; ++o)
        y[o] = acc[o] > 0.0f ? acc[o] : 0.0f;
      roundHalfArray(y, W); // ReLU, then the fp16 activation of the next operand
      Wt += static_cast<size_t>(inDim) * W;
      in = y;
      inDim = W;
    }
    float o = 0.0f;
    for (int i = 0; i < W; ++i)
      o += in[i] * net.Output[i];
    out[s] = o;
  }
}

} // namespace nv
