// Shared pieces of the render tests: an analytic field and a small trained model, cameras, transfer functions,
// image comparison and binary PPM files.
#pragma once

#include "Core/Engine.h"
#include "Core/Model.h"
#include "Core/Render.h"
#include "Cpu/CpuRenderer.h"
#include "Cpu/ThreadPool.h"
#include "SessionHelpers.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace nvtest
{

// ---------------------------------------------------------------------------------------------------------
// Matrices: row-major 4x4, OpenGL conventions.

struct Mat4
{
  double m[16] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 };
};

inline Mat4 mul(const Mat4& a, const Mat4& b)
{
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
    {
      double s = 0;
      for (int k = 0; k < 4; ++k)
        s += a.m[4 * i + k] * b.m[4 * k + j];
      r.m[4 * i + j] = s;
    }
  return r;
}

inline Mat4 lookAt(const double eye[3], const double center[3], const double up[3])
{
  double f[3] = { center[0] - eye[0], center[1] - eye[1], center[2] - eye[2] };
  auto norm = [](double* v) {
    const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; ++i)
      v[i] /= l;
  };
  norm(f);
  double s[3] = { f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0] };
  norm(s);
  const double u[3] = { s[1] * f[2] - s[2] * f[1], s[2] * f[0] - s[0] * f[2], s[0] * f[1] - s[1] * f[0] };
  Mat4 v;
  for (int i = 0; i < 3; ++i)
  {
    v.m[i] = s[i];
    v.m[4 + i] = u[i];
    v.m[8 + i] = -f[i];
  }
  v.m[3] = -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]);
  v.m[7] = -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]);
  v.m[11] = f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2];
  return v;
}

inline Mat4 perspective(double fovyDegrees, double aspect, double n, double f)
{
  const double t = 1.0 / std::tan(fovyDegrees * 3.14159265358979 / 360.0);
  Mat4 p;
  p.m[0] = t / aspect;
  p.m[5] = t;
  p.m[10] = -(f + n) / (f - n);
  p.m[11] = -2.0 * f * n / (f - n);
  p.m[14] = -1.0;
  p.m[15] = 0.0;
  return p;
}

inline Mat4 ortho(double l, double r, double b, double t, double n, double f)
{
  Mat4 p;
  p.m[0] = 2.0 / (r - l);
  p.m[3] = -(r + l) / (r - l);
  p.m[5] = 2.0 / (t - b);
  p.m[7] = -(t + b) / (t - b);
  p.m[10] = -2.0 / (f - n);
  p.m[11] = -(f + n) / (f - n);
  return p;
}

/// Window depth in [0,1] of world point p under a view-projection.
inline double windowDepth(const Mat4& vp, const double p[3])
{
  const double* m = vp.m;
  const double z = m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11];
  const double w = m[12] * p[0] + m[13] * p[1] + m[14] * p[2] + m[15];
  return 0.5 * (z / w + 1.0);
}

/// World box [-1,1]^3 -> network coordinates [0,1]^3.
inline void unitBox(double* w2u)
{
  const double m[16] = { 0.5, 0, 0, 0.5, 0, 0.5, 0, 0.5, 0, 0, 0.5, 0.5, 0, 0, 0, 1 };
  std::copy(m, m + 16, w2u);
}

inline void setCamera(nv::RenderRequest& q, const Mat4& vp)
{
  std::copy(vp.m, vp.m + 16, q.viewProjection);
}

/// Orthographic view along -z of the box [-1,1]^3: x in [-1.2, 1.2] across the width, y in [-1, 1] up the height.
inline Mat4 orthoAlongZ()
{
  const double eye[3] = { 0, 0, 5 }, c[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
  return mul(ortho(-1.2, 1.2, -1.0, 1.0, 0.5, 20.0), lookAt(eye, c, up));
}

/// A domain mask (SourceInfo::domain) keeping the source samples with x index < (nx - 1) / 2: the half u_x < 0.5.
inline void keepHalfX(nv::Model& m)
{
  const int64_t* n = m.source.dims;
  m.source.domain.assign(size_t((n[0] * n[1] * n[2] + 31) / 32), 0u);
  for (int64_t z = 0; z < n[2]; ++z)
    for (int64_t y = 0; y < n[1]; ++y)
      for (int64_t x = 0; x < (n[0] - 1) / 2; ++x)
      {
        const int64_t i = (z * n[1] + y) * n[0] + x;
        m.source.domain[size_t(i >> 5)] |= 1u << (i & 31);
      }
}

/// A sparse source's occupancy (SourceInfo::occupancy): the macrocells of the half x < 0.5 of the box occupied, the
/// others the background `background` exactly.
inline void occupyHalfX(nv::Model& m, double background)
{
  const nv::MacrocellLayout cells = nv::macrocellLayout(m.source.dims);
  m.source.occupancy.assign(size_t(nv::occupancyWords(m.source.dims)), 0u);
  for (int z = 0; z < cells.dims[2]; ++z)
    for (int y = 0; y < cells.dims[1]; ++y)
      for (int x = 0; x < cells.dims[0] / 2; ++x)
      {
        const int64_t c = (int64_t(z) * cells.dims[1] + y) * cells.dims[0] + x;
        m.source.occupancy[size_t(c >> 5)] |= 1u << (c & 31);
      }
  m.source.background = background;
}

/// The tests' default view: perspective from an oblique direction, the box filling most of the frame.
inline Mat4 defaultCamera(int w, int h)
{
  const double eye[3] = { 2.2, 1.6, 2.9 }, c[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
  return mul(perspective(36.0, double(w) / h, 0.5, 20.0), lookAt(eye, c, up));
}

// ---------------------------------------------------------------------------------------------------------
// Fields and models

/// Two smooth blobs and a spherical shell, values in [0,1], ~0 near the faces (empty space for skipping).
inline double blobField(double x, double y, double z)
{
  auto g = [](double dx, double dy, double dz, double s) {
    return std::exp(-(dx * dx + dy * dy + dz * dz) / (2 * s * s));
  };
  const double r = std::sqrt((x + 0.15) * (x + 0.15) + (y - 0.25) * (y - 0.25) + (z + 0.2) * (z + 0.2));
  return 0.95 * g(x - 0.35, y + 0.25, z - 0.2, 0.22) + 0.75 * g(x + 0.4, y + 0.4, z - 0.3, 0.18) +
    0.6 * std::exp(-(r - 0.45) * (r - 0.45) / (2 * 0.06 * 0.06));
}

inline std::vector<float> blobVolume(int n)
{
  std::vector<float> v(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        v[(size_t(z) * n + y) * n + x] =
          float(blobField(2.0 * x / (n - 1) - 1, 2.0 * y / (n - 1) - 1, 2.0 * z / (n - 1) - 1));
  return v;
}

inline nv::VolumeView viewOf(const std::vector<float>& v, int64_t nx, int64_t ny, int64_t nz)
{
  nv::VolumeView vol;
  vol.data = v.data();
  vol.type = nv::ScalarType::Float32;
  vol.dims[0] = nx;
  vol.dims[1] = ny;
  vol.dims[2] = nz;
  const nv::VolumeStats s = nv::computeStats(vol);
  vol.valueMin = s.min;
  vol.valueMax = s.max;
  return vol;
}

inline nv::ModelConfig smallRenderConfig()
{
  nv::ModelConfig c;
  c.encoding.levels = 8;
  c.encoding.featuresPerLevel = 2;
  c.encoding.log2TableSize = 12;
  c.encoding.baseResolution = 4;
  c.encoding.finestResolution = 64;
  c.network.width = 32;
  c.network.hiddenLayers = 2;
  return c;
}

/// A model of `vol` trained with one thread and a fixed seed: bit-reproducible.
inline nv::Model trainModel(const nv::VolumeView& vol, const nv::ModelConfig& config, int steps, int batch,
  uint64_t seed = 3, int threads = 1)
{
  nv::Model m(config);
  m.initialize(seed);
  m.source.valueMin = vol.valueMin;
  m.source.valueMax = vol.valueMax;
  for (int a = 0; a < 3; ++a)
    m.source.dims[a] = vol.dims[a];
  nv::TrainConfig tc;
  tc.batchSize = batch;
  tc.seed = seed;
  tc.threads = threads;
  auto tr = createTrainer(nv::Device::Cpu, m, vol, tc); // SessionHelpers: a CPU session's trainer
  tr->steps(steps, nullptr);
  tr->syncTo(m);
  return m;
}

// ---------------------------------------------------------------------------------------------------------
// Requests

/// Blue -> orange -> white, transparent below 0.15 of the range, opacity up to `peak` per unit distance.
inline nv::TransferFunction blobTransfer(double valueMin, double valueMax, float peak = 0.8f)
{
  nv::TransferFunction tf;
  const int n = 64;
  for (int i = 0; i < n; ++i)
  {
    const float u = float(i) / (n - 1);
    const float a = u < 0.15f ? 0.0f : peak * std::min(1.0f, (u - 0.15f) / 0.5f);
    tf.rgba.insert(tf.rgba.end(),
      { 0.15f + 0.85f * std::min(1.0f, 1.6f * u), 0.3f + 0.5f * u, 0.9f - 0.6f * u, a });
  }
  tf.valueMin = valueMin;
  tf.valueMax = valueMax;
  tf.unitDistance = 0.05;
  return tf;
}

inline nv::RenderRequest blobRequest(const nv::Model& m, nv::RenderPath path, nv::ShadingMode mode, int w = 64,
  int h = 64)
{
  nv::RenderRequest q;
  q.width = w;
  q.height = h;
  setCamera(q, defaultCamera(w, h));
  unitBox(q.worldToUnit);
  q.transfer = blobTransfer(m.source.valueMin, m.source.valueMax);
  q.path = path;
  q.shading = mode;
  q.lightDirection[0] = 0.6;
  q.lightDirection[1] = 0.8;
  q.lightDirection[2] = 0.4;
  q.sunAngle = 30.0;
  q.maxBounces = 3;
  q.samplesPerPixel = 16;
  return q;
}

// ---------------------------------------------------------------------------------------------------------
// Images

/// The blob request for path tracing the grid itself (RenderRequest::grid, Decode path) with the request's default
/// light (sky, sun, sun angle, bounces, phase) but for the blob's light direction.
inline nv::RenderRequest gridPathTracingRequest(const nv::Model& m, const nv::VolumeView& grid, nv::ShadingMode mode,
  int w, int h)
{
  nv::RenderRequest q = blobRequest(m, nv::RenderPath::Decode, mode, w, h);
  const nv::RenderRequest defaults;
  q.sunAngle = defaults.sunAngle;
  q.maxBounces = defaults.maxBounces;
  q.ambient = defaults.ambient;
  q.diffuse = defaults.diffuse;
  q.anisotropy = defaults.anisotropy;
  q.grid = &grid;
  return q;
}

/// The blob on an n^3 grid with an untrained model of its extent and value range: path-tracing tests render the
/// grid itself through the Decode path (RenderRequest::grid), so that only the renderer is measured.
struct BlobGridScene
{
  explicit BlobGridScene(int n)
    : data(blobVolume(n))
    , grid(viewOf(data, n, n, n))
    , model(smallRenderConfig())
  {
    model.initialize(1);
    for (int a = 0; a < 3; ++a)
      model.source.dims[a] = n;
    model.source.valueMin = grid.valueMin;
    model.source.valueMax = grid.valueMax;
  }
  std::vector<float> data;
  nv::VolumeView grid;
  nv::Model model;
};

inline bool allFinite(const std::vector<float>& v)
{
  for (float x : v)
    if (!std::isfinite(x))
      return false;
  return true;
}

/// PSNR (dB) over every channel of two premultiplied RGBA images, values clamped to [0,1]; +inf when identical.
inline double psnr(const std::vector<float>& a, const std::vector<float>& b)
{
  if (a.size() != b.size() || a.empty() || !allFinite(a) || !allFinite(b))
    return -1.0;
  double se = 0.0;
  for (size_t i = 0; i < a.size(); ++i)
  {
    const double d = std::min(1.0f, std::max(0.0f, a[i])) - std::min(1.0f, std::max(0.0f, b[i]));
    se += d * d;
  }
  return se == 0.0 ? INFINITY : 10.0 * std::log10(double(a.size()) / se);
}

inline double meanChannel(const std::vector<float>& img, int c)
{
  double s = 0;
  for (size_t i = c; i < img.size(); i += 4)
    s += img[i];
  return s / double(img.size() / 4);
}

/// 8-bit RGB of a premultiplied image over a grey background, rows top first (as PPM stores them).
inline std::vector<unsigned char> toRgb8(const std::vector<float>& rgba, int w, int h)
{
  const float bg[3] = { 0.22f, 0.22f, 0.26f };
  std::vector<unsigned char> out(size_t(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const float* p = &rgba[4 * (size_t(h - 1 - y) * w + x)];
      for (int c = 0; c < 3; ++c)
      {
        const float v = p[c] + (1.0f - std::min(1.0f, p[3])) * bg[c];
        out[3 * (size_t(y) * w + x) + c] = (unsigned char)std::lround(255.0f * std::min(1.0f, std::max(0.0f, v)));
      }
    }
  return out;
}

inline bool writePpm(const std::string& path, const std::vector<unsigned char>& rgb, int w, int h)
{
  std::ofstream f(path, std::ios::binary);
  f << "P6\n" << w << " " << h << "\n255\n";
  f.write(reinterpret_cast<const char*>(rgb.data()), std::streamsize(rgb.size()));
  return bool(f);
}

inline bool readPpm(const std::string& path, std::vector<unsigned char>& rgb, int& w, int& h)
{
  std::ifstream f(path, std::ios::binary);
  std::string magic;
  int maxv = 0;
  if (!(f >> magic >> w >> h >> maxv) || magic != "P6" || maxv != 255)
    return false;
  f.get();
  rgb.resize(size_t(w) * h * 3);
  f.read(reinterpret_cast<char*>(rgb.data()), std::streamsize(rgb.size()));
  return bool(f);
}

/// PSNR (dB) of two 8-bit images.
inline double psnr8(const std::vector<unsigned char>& a, const std::vector<unsigned char>& b)
{
  if (a.size() != b.size() || a.empty())
    return -1.0;
  double se = 0.0;
  for (size_t i = 0; i < a.size(); ++i)
  {
    const double d = (double(a[i]) - double(b[i])) / 255.0;
    se += d * d;
  }
  return se == 0.0 ? INFINITY : 10.0 * std::log10(double(a.size()) / se);
}

} // namespace nvtest
