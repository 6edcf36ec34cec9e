// NeuralVolume engine: the bias-free ReLU MLP on the CPU, evaluated on tiles of samples.
#pragma once

#include <cstddef>
#include <cstdint>

namespace nv
{

class Model;

/// Shape of the network: inputs -> width (x hidden layers, ReLU) -> 1 (linear). Weights are one block,
/// layer after layer, each row-major [out][in] (PyTorch's nn.Linear layout).
class CpuMlp
{
public:
  CpuMlp(int inputs, int width, int hidden);
  explicit CpuMlp(const Model& model);

  int inputs() const { return Inputs; }
  int width() const { return Width; }
  int hidden() const { return Hidden; }
  size_t paramCount() const;
  size_t layerOffset(int l) const;
  int layerIn(int l) const { return l == 0 ? Inputs : Width; }
  int layerOut(int l) const { return l == Hidden ? 1 : Width; }

  /// WT receives every layer transposed ([in][out]), same offsets as W; forward() reads it.
  void transpose(const float* W, float* WT) const;

  /// Forward for n samples: in is n x inputs; acts receives hidden x n x width post-ReLU activations; out n.
  void forward(const float* WT, const float* in, int n, float* acts, float* out) const;

  /// Backward: accumulates dW (+=), writes dIn (n x inputs) when non-null. scratch: 2 * n * width floats.
  void backward(const float* W, const float* in, const float* acts, const float* dOut, int n, float* dW, float* dIn,
    float* scratch) const;

private:
  int Inputs;
  int Width;
  int Hidden;
};

} // namespace nv
