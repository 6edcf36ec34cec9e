// Test shorthands over NetworkSession: one-shot inference, decoding, error and trainers that keep their session.
// Production code holds a session for the network's lifetime; these create one per call, which is fine in tests.
#pragma once

#include "Core/Engine.h"
#include "Core/NetworkSession.h"

#include <memory>
#include <type_traits>
#include <vector>

namespace nvtest
{

/// An n^3 volume over v (float32 or float64) with its own value range.
template <typename T>
nv::VolumeView cubeView(const std::vector<T>& v, int n)
{
  static_assert(std::is_same<T, float>::value || std::is_same<T, double>::value, "float32 or float64 volumes");
  nv::VolumeView vol;
  vol.data = v.data();
  vol.type = std::is_same<T, float>::value ? nv::ScalarType::Float32 : nv::ScalarType::Float64;
  vol.dims[0] = vol.dims[1] = vol.dims[2] = n;
  const nv::VolumeStats s = nv::computeStats(vol);
  vol.valueMin = s.min;
  vol.valueMax = s.max;
  return vol;
}

/// An n^3 float32 volume of f(X, Y, Z) at the samples, X, Y, Z in [0, 1] (x fastest).
template <typename F>
std::vector<float> sampledCube(int n, F f)
{
  std::vector<float> v(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        v[(size_t(z) * n + y) * n + x] =
          static_cast<float>(f(double(x) / (n - 1), double(y) / (n - 1), double(z) / (n - 1)));
  return v;
}

/// An initialised (untrained) network of `config` for `vol`'s value range.
inline nv::Model untrainedModel(const nv::ModelConfig& config, const nv::VolumeView& vol, uint64_t seed)
{
  nv::Model m(config);
  m.initialize(seed);
  m.source.valueMin = vol.valueMin;
  m.source.valueMax = vol.valueMax;
  return m;
}

/// A small network for fast CPU tests: 8 levels x 2 features, finest 64, MLP 32 x 2.
inline nv::ModelConfig smallModelConfig(int log2TableSize)
{
  nv::ModelConfig c;
  c.encoding.levels = 8;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = log2TableSize;
  c.encoding.finestResolution = 64;
  c.network.width = 32;
  c.network.hiddenLayers = 2;
  return c;
}

/// Kernel variants of every session the helpers create (GPU tests set them from command-line flags).
inline nv::KernelOptions& kernelOptions()
{
  static nv::KernelOptions k;
  return k;
}

inline std::unique_ptr<nv::NetworkSession> session(const nv::Model& m, nv::Device d = nv::Device::Cpu,
  int threads = 0)
{
  nv::SessionOptions o;
  o.threads = threads;
  o.kernels = kernelOptions();
  return nv::NetworkSession::create(d, m, o);
}

/// Normalised outputs.
inline void inferPoints(const nv::Model& m, const float* xyz, int64_t n, float* out, nv::Device d = nv::Device::Cpu,
  int threads = 0)
{
  session(m, d, threads)->inferPoints(xyz, n, out, nv::Memory::Host);
}

/// Normalised outputs of grid slices [z0, z1).
inline void decodeGridNormalized(const nv::Model& m, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1,
  float* out, nv::Device d = nv::Device::Cpu, int threads = 0)
{
  session(m, d, threads)->decodeGrid(nx, ny, nz, z0, z1, out, nv::Memory::Host);
}

/// De-normalised (source units) grid slices [z0, z1).
inline void decodeGrid(const nv::Model& m, int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out,
  nv::Device d = nv::Device::Cpu, int threads = 0)
{
  auto s = session(m, d, threads);
  nv::decodeGridValues(*s, nx, ny, nz, z0, z1, out);
}

inline nv::ErrorStats compareToSource(const nv::Model& m, const nv::VolumeView& v, nv::Device d = nv::Device::Cpu,
  int threads = 0)
{
  auto s = session(m, d, threads);
  return nv::compareToSource(*s, v);
}

/// A trainer together with the session it trains (the session must outlive the trainer).
struct SessionTrainer
{
  std::unique_ptr<nv::NetworkSession> s;
  std::unique_ptr<nv::Trainer> t;
  nv::Trainer* operator->() const { return t.get(); }
};

inline SessionTrainer createTrainer(nv::Device d, const nv::Model& m, const nv::VolumeView& v,
  const nv::TrainConfig& c)
{
  SessionTrainer st;
  st.s = session(m, d, c.threads);
  st.t = st.s->createTrainer(v, c);
  return st;
}

inline SessionTrainer createTrainer(nv::Device d, const nv::Model& m, const nv::TrainingPoints& p,
  const nv::TrainConfig& c)
{
  SessionTrainer st;
  st.s = session(m, d, c.threads);
  st.t = st.s->createTrainer(p, c);
  return st;
}

} // namespace nvtest
