// nvBench render: CPU renderer frame times.
//   nvBench render PATH MODE W H [volume.nhdr] [steps=N] [spp=N] [K=N] [frames=N] [model=FILE] [skip=0|1]
//                [lattice=N]
// PATH: decode | streaming | inshader; MODE: rm | rmgrad | rmshadow | pt | ptnee. Without a volume: an analytic
// 64^3 field. The network is the method's (16x4 levels, 2^14 table, 64x4 MLP) trained `steps` steps (default 300,
// batch 16384, seed 1) or loaded from / saved to `model`. Camera: perspective, 30-degree field of view, the
// volume's bounding sphere spanning 83% of the frame height; it orbits by 1 degree per frame (every frame
// is traced: no cache hit). Opacity: transparent up to the 75th percentile of the values (air), then a ramp.
// Prints RESULT {json}: the first frame (decode / macrocells included; progressive Decode: whether it used the
// coarse grid, and the time until the full grid was shown), then the median of the next `frames`.
#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "Core/Render.h"
#include "Core/RenderSetup.h"
#include "Core/Serialization.h"
#include "Cpu/CpuRenderer.h"
#include "Cpu/ThreadPool.h"
#include "Nhdr.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

using namespace nv;

namespace
{
using Clock = std::chrono::steady_clock;

void mul4(const double* a, const double* b, double* r)
{
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
    {
      double s = 0;
      for (int k = 0; k < 4; ++k)
        s += a[4 * i + k] * b[4 * k + j];
      r[4 * i + j] = s;
    }
}

/// World = voxel coordinates (spacing 1); the camera orbits the centre at `angle` degrees.
void camera(const int64_t dims[3], int w, int h, double angle, RenderRequest& q)
{
  const double c[3] = { 0.5 * (dims[0] - 1), 0.5 * (dims[1] - 1), 0.5 * (dims[2] - 1) };
  const double radius = 0.5 * std::sqrt(double((dims[0] - 1) * (dims[0] - 1) + (dims[1] - 1) * (dims[1] - 1) +
    (dims[2] - 1) * (dims[2] - 1)));
  const double fov = 30.0 * 3.14159265358979 / 180.0;
  const double dist = radius / std::tan(fov / 2) * 1.2; // the bounding sphere spans 83% of the frame height
  const double a = angle * 3.14159265358979 / 180.0;
  const double dir[3] = { std::cos(a) * 0.8, 0.45, std::sin(a) * 0.8 + 0.35 };
  const double dl = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  double eye[3], f[3], s[3], u[3];
  for (int i = 0; i < 3; ++i)
  {
    eye[i] = c[i] + dist * dir[i] / dl;
    f[i] = -dir[i] / dl;
  }
  const double up[3] = { 0, 1, 0 };
  s[0] = f[1] * up[2] - f[2] * up[1];
  s[1] = f[2] * up[0] - f[0] * up[2];
  s[2] = f[0] * up[1] - f[1] * up[0];
  const double sl = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  for (double& x : s)
    x /= sl;
  u[0] = s[1] * f[2] - s[2] * f[1];
  u[1] = s[2] * f[0] - s[0] * f[2];
  u[2] = s[0] * f[1] - s[1] * f[0];
  double view[16] = { s[0], s[1], s[2], 0, u[0], u[1], u[2], 0, -f[0], -f[1], -f[2], 0, 0, 0, 0, 1 };
  view[3] = -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]);
  view[7] = -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]);
  view[11] = f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2];
  const double n = dist - 2 * radius, fa = dist + 2 * radius, t = 1.0 / std::tan(fov / 2);
  const double proj[16] = { t * h / w, 0, 0, 0, 0, t, 0, 0, 0, 0, -(fa + n) / (fa - n), -2 * fa * n / (fa - n), 0, 0,
    -1, 0 };
  mul4(proj, view, q.viewProjection);
  std::fill(q.worldToUnit, q.worldToUnit + 16, 0.0);
  for (int i = 0; i < 3; ++i)
    q.worldToUnit[5 * i] = dims[i] > 1 ? 1.0 / double(dims[i] - 1) : 1.0;
  q.worldToUnit[15] = 1.0;
}

/// Transparent up to the 75th percentile of the values (air and background), a ramp to opacity 0.5 per voxel at
/// the 99th percentile, 0.5 above; colours from blue to warm white over the range.
TransferFunction airTransparent(const VolumeView& v)
{
  std::vector<double> values;
  values.reserve(size_t(v.count()));
  for (int64_t i = 0; i < v.count(); ++i)
    if (std::isfinite(v.at(i)))
      values.push_back(v.at(i));
  std::sort(values.begin(), values.end());
  const double lo = v.valueMin, hi = v.valueMax;
  const double p75 = values[values.size() * 3 / 4], p99 = values[values.size() * 99 / 100];
  TransferFunction tf;
  const int n = 256;
  for (int i = 0; i < n; ++i)
  {
    const double x = lo + (hi - lo) * i / (n - 1);
    const float a = x <= p75 ? 0.0f : float(std::min(1.0, (x - p75) / std::max(p99 - p75, 1e-12)) * 0.5);
    const float u = float(i) / (n - 1);
    tf.rgba.insert(tf.rgba.end(), { 0.3f + 0.7f * std::sqrt(u), 0.25f + 0.6f * u, 0.8f - 0.4f * u, a });
  }
  tf.valueMin = lo;
  tf.valueMax = hi;
  tf.unitDistance = 1.0; // one voxel
  return tf;
}
} // namespace

int renderBenchmark(int argc, char** argv)
{
  if (argc < 6)
  {
    std::fprintf(stderr, "usage: nvBench render PATH MODE W H [volume.nhdr] [steps=N] [spp=N] [K=N] [frames=N] "
                         "[model=FILE] [skip=0|1]\n");
    return 2;
  }
  const std::map<std::string, RenderPath> paths = { { "decode", RenderPath::Decode },
    { "streaming", RenderPath::SampleStreaming }, { "inshader", RenderPath::InShader } };
  const std::map<std::string, ShadingMode> modes = { { "rm", ShadingMode::RayMarch },
    { "rmgrad", ShadingMode::RayMarchGradient }, { "rmshadow", ShadingMode::RayMarchShadows },
    { "pt", ShadingMode::PathTrace }, { "ptnee", ShadingMode::PathTraceNee } };
  if (!paths.count(argv[2]) || !modes.count(argv[3]))
  {
    std::fprintf(stderr, "unknown path %s or mode %s\n", argv[2], argv[3]);
    return 2;
  }
  std::string volume, modelFile;
  int steps = 300, spp = 1, K = 0, frames = 5;
  bool skip = true;
  CpuRendererOptions options;
  for (int i = 6; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto value = [&](const char* k) { return a.rfind(k, 0) == 0 ? a.substr(std::string(k).size()) : std::string(); };
    if (!value("steps=").empty())
      steps = std::stoi(value("steps="));
    else if (!value("spp=").empty())
      spp = std::stoi(value("spp="));
    else if (!value("K=").empty())
      K = std::stoi(value("K="));
    else if (!value("frames=").empty())
      frames = std::max(1, std::stoi(value("frames=")));
    else if (!value("model=").empty())
      modelFile = value("model=");
    else if (!value("lattice=").empty())
      options.latticeMax = std::stoi(value("lattice="));
    else if (!value("skip=").empty())
      skip = value("skip=") != "0";
    else
      volume = a;
  }

  nvbench::RawVolume raw;
  if (!volume.empty())
    raw = nvbench::loadNhdr(volume);
  else
  {
    const int n = 64;
    raw.name = "analytic64";
    raw.bytes.resize(size_t(n) * n * n * sizeof(float));
    float* v = reinterpret_cast<float*>(raw.bytes.data());
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
        {
          const double X = 2.0 * x / (n - 1) - 1, Y = 2.0 * y / (n - 1) - 1, Z = 2.0 * z / (n - 1) - 1;
          const double r = std::sqrt(X * X + Y * Y + Z * Z);
          v[(size_t(z) * n + y) * n + x] = float(std::exp(-(r - 0.55) * (r - 0.55) / 0.02) +
            0.8 * std::exp(-((X - 0.2) * (X - 0.2) + Y * Y + (Z + 0.1) * (Z + 0.1)) / 0.05));
        }
    raw.view.data = raw.bytes.data();
    raw.view.type = ScalarType::Float32;
    raw.view.dims[0] = raw.view.dims[1] = raw.view.dims[2] = n;
    const VolumeStats s = computeStats(raw.view);
    raw.view.valueMin = s.min;
    raw.view.valueMax = s.max;
  }

  Model m;
  double trainSeconds = 0.0;
  if (!modelFile.empty() && std::ifstream(modelFile))
    m = loadModel(modelFile);
  else
  {
    m = nvbench::modelFor(raw, 14, 1);
    for (int a = 0; a < 3; ++a)
      m.source.dims[a] = raw.view.dims[a];
    TrainConfig tc;
    tc.batchSize = 16384;
    const auto t0 = Clock::now();
    auto session = NetworkSession::create(Device::Cpu, m);
    auto tr = session->createTrainer(raw.view, tc);
    tr->steps(steps, nullptr);
    tr->syncTo(m);
    trainSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    m.quantize(Precision::Float16);
    if (!modelFile.empty())
      saveModel(m, modelFile);
  }

  ThreadPool pool(0);
  CpuRenderer renderer(pool, options);
  RenderRequest q;
  q.width = std::atoi(argv[4]);
  q.height = std::atoi(argv[5]);
  q.path = paths.at(argv[2]);
  q.shading = modes.at(argv[3]);
  q.transfer = airTransparent(raw.view);
  q.samplesPerPixel = spp;
  q.streamingSamples = K;
  q.emptySpaceSkipping = skip;
  q.lightDirection[0] = 0.5;
  q.lightDirection[1] = 0.8;
  q.lightDirection[2] = 0.3;
  q.sunAngle = 10.0;
  RenderResult res;
  std::vector<double> ms;
  RenderStats first;
  double refineMs = 0.0; // progressive Decode: until the full grid is shown
  for (int f = 0; f <= frames; ++f)
  {
    if (f == 1)
    {
      const auto t0 = Clock::now();
      while (renderer.workPending())
      {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        renderer.render(m, 1, q, res);
      }
      refineMs = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    }
    camera(m.source.dims, q.width, q.height, double(f), q);
    const auto t0 = Clock::now();
    renderer.render(m, 1, q, res);
    const double t = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (f == 0)
    {
      first = res.stats;
      first.renderMilliseconds = t; // whole call
    }
    else
      ms.push_back(t);
  }
  std::sort(ms.begin(), ms.end());
  const RenderStats& s = res.stats;
  double alpha = 0.0;
  for (size_t i = 3; i < res.rgba.size(); i += 4)
    alpha += res.rgba[i];
  std::printf("RESULT {\"what\":\"cpu_render\",\"name\":\"%s\",\"dims\":[%lld,%lld,%lld],\"threads\":%d,"
              "\"path\":\"%s\",\"mode\":\"%s\",\"width\":%d,\"height\":%d,\"spp\":%d,\"K\":%d,\"skipping\":%d,"
              "\"lattice_max\":%d,"
              "\"train_s\":%.1f,\"first_frame_ms\":%.1f,\"first_decode_ms\":%.1f,\"first_pending\":%d,"
              "\"refine_ms\":%.0f,\"ms_median\":%.1f,\"ms_min\":%.1f,\"fps\":%.2f,\"rays\":%lld,"
              "\"samples_evaluated\":%lld,\"samples_plain\":%lld,\"wavefronts\":%lld,"
              "\"evaluated_per_s\":%.4g,\"coverage\":%.3f}\n",
    raw.name.c_str(), (long long)m.source.dims[0], (long long)m.source.dims[1], (long long)m.source.dims[2],
    pool.size(), argv[2], argv[3], q.width, q.height, spp,
    q.streamingSamples ? q.streamingSamples : kDefaultStreamingSamples, skip ? 1 : 0, options.latticeMax,
    trainSeconds, first.renderMilliseconds, first.decodeMilliseconds, first.decodePending ? 1 : 0, refineMs,
    ms[ms.size() / 2], ms.front(),
    1000.0 / ms[ms.size() / 2], (long long)s.rays, (long long)s.samplesEvaluated, (long long)s.samplesPlain,
    (long long)s.wavefronts, double(s.samplesEvaluated) / (ms[ms.size() / 2] * 1e-3),
    alpha / double(q.width) / q.height);
  return 0;
}
