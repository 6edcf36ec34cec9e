// How fast a still path-traced picture converges, raw and denoised (issue 24): PSNR against the picture of
// --reference paths per pixel (PT and PT+NEE, the blob scene of the engine tests and the stent CT), the CPU engine's
// Decode path of an explicit grid. Raw and denoised accumulations of 1 path per render (the interactive
// accumulation: the denoiser's variance from the frames' moments), and single renders of N paths (one frame: the
// spatial variance). Prints markdown tables (Testing/Benchmarks/results/pt_convergence_2026-11-27.md).
//   nvBenchPtConvergence [--size 64] [--reference 4096] [--stent path.nhdr] [--ppm folder] [--cache folder]
// (--cache: the reference pictures are kept there as raw floats and read back by the next run.)
#include "Nhdr.h"
#include "RenderFixtures.h"

#include <chrono>
#include <fstream>
#include <cstdio>
#include <cstring>

using namespace nv;
using namespace nvtest;

namespace
{
constexpr int kBlobGrid = 48;
const int kSpp[] = { 1, 2, 4, 8, 16, 32, 64, 256 };
constexpr double kConvergedDb = 35.0;

struct Scene
{
  std::string name;
  VolumeView grid;
  Model model{ smallRenderConfig() };
  TransferFunction transfer;
};

double seconds(std::chrono::steady_clock::time_point t0)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

RenderRequest sceneRequest(const Scene& s, ShadingMode mode, int size)
{
  RenderRequest q = gridPathTracingRequest(s.model, s.grid, mode, size, size);
  q.transfer = s.transfer;
  return q;
}

std::vector<float> renderPaths(ThreadPool& pool, const Scene& s, RenderRequest q, int paths, int perCall)
{
  CpuRenderer r(pool);
  q.samplesPerPixel = std::min(paths, perCall);
  RenderResult res;
  for (int done = 0; done < paths; done += q.samplesPerPixel)
    r.render(s.model, 1, q, res);
  return res.rgba;
}

/// The reference picture, read from `cache` when it has it (else rendered and written there).
std::vector<float> referencePicture(ThreadPool& pool, const Scene& s, const RenderRequest& q, int paths,
  const std::string& cache, double& renderSeconds)
{
  const std::string file = cache.empty() ? std::string() : cache + "/" + s.name + "_" + std::to_string(int(q.shading)) +
      "_" + std::to_string(q.width) + "_" + std::to_string(paths) + "_seed" + std::to_string(q.seed) + ".f32";
  std::vector<float> img(size_t(q.width) * q.height * 4);
  renderSeconds = 0.0;
  if (!file.empty())
  {
    std::ifstream in(file, std::ios::binary);
    if (in.read(reinterpret_cast<char*>(img.data()), std::streamsize(img.size() * sizeof(float))))
      return img;
  }
  const auto t0 = std::chrono::steady_clock::now();
  img = renderPaths(pool, s, q, paths, 256);
  renderSeconds = seconds(t0);
  if (!file.empty())
    std::ofstream(file, std::ios::binary).write(reinterpret_cast<const char*>(img.data()),
      std::streamsize(img.size() * sizeof(float)));
  return img;
}

void writeImage(const std::string& folder, const std::string& name, const std::vector<float>& rgba, int size)
{
  if (!folder.empty())
    writePpm(folder + "/" + name + ".ppm", toRgb8(rgba, size, size), size, size);
}

/// One scene and mode: the PSNR table (accumulated 1 path per render, raw and denoised; one render of N paths
/// denoised) and the denoiser's times.
void measure(ThreadPool& pool, const Scene& s, ShadingMode mode, int size, int referencePaths, const std::string& ppm,
  const std::string& cache)
{
  RenderRequest q = sceneRequest(s, mode, size);
  double refSeconds = 0.0;
  RenderRequest qRef = q;
  qRef.seed = 12345; // independent paths (the measured accumulations' paths would be a subset of the reference's)
  const std::vector<float> reference = referencePicture(pool, s, qRef, referencePaths, cache, refSeconds);
  const std::string tag = s.name + "_" + (mode == ShadingMode::PathTrace ? "pt" : "nee");
  writeImage(ppm, tag + "_reference", reference, size);
  std::printf("\n### %s, %s, %d x %d (reference: %d paths per pixel, %.1f s; 0: cached)\n\n", s.name.c_str(),
    shadingModeName(mode), size, size, referencePaths, refSeconds);
  std::printf("| paths/pixel | raw dB | denoised dB (1 path per render) | denoised dB (one render) | pass ms | "
              "denoise ms | guide ms |\n|---|---|---|---|---|---|---|\n");
  CpuRenderer raw(pool), denoised(pool);
  RenderRequest qr = q, qd = q;
  qr.samplesPerPixel = qd.samplesPerPixel = 1;
  qd.denoise = true;
  RenderResult rr, rd;
  int done = 0;
  double guideMs = 0.0;
  for (int spp : kSpp)
  {
    double passMs = 0.0, denoiseMs = 0.0;
    for (; done < spp; ++done)
    {
      raw.render(s.model, 1, qr, rr);
      denoised.render(s.model, 1, qd, rd);
      passMs = rr.stats.renderMilliseconds;
      denoiseMs = rd.stats.denoiseMilliseconds;
      guideMs += rd.stats.guideMilliseconds;
    }
    RenderRequest once = qd;
    once.samplesPerPixel = spp;
    const std::vector<float> single = renderPaths(pool, s, once, spp, spp);
    std::printf("| %d | %.2f | %.2f | %.2f | %.1f | %.2f | %.1f |\n", spp, psnr(rr.rgba, reference),
      psnr(rd.rgba, reference), psnr(single, reference), passMs, denoiseMs, guideMs);
    if (spp == kSpp[sizeof(kSpp) / sizeof(kSpp[0]) - 1])
    {
      std::printf("\nAt %d paths, PSNR per channel r g b a, raw / denoised:", spp);
      for (int c = 0; c < 4; ++c)
      {
        std::vector<float> a, b, d;
        for (size_t i = c; i < reference.size(); i += 4)
        {
          a.push_back(reference[i]);
          b.push_back(rr.rgba[i]);
          d.push_back(rd.rgba[i]);
        }
        std::printf(" %.1f / %.1f", psnr(b, a), psnr(d, a));
      }
      std::printf("\n");
    }
    if (spp == 8 || spp == 64)
    {
      writeImage(ppm, tag + "_raw" + std::to_string(spp), rr.rgba, size);
      writeImage(ppm, tag + "_denoised" + std::to_string(spp), rd.rgba, size);
    }
  }
}

void makeBlobScene(Scene& s)
{
  static std::vector<float> data = blobVolume(kBlobGrid);
  s.name = "blob";
  s.grid = viewOf(data, kBlobGrid, kBlobGrid, kBlobGrid);
  s.model.initialize(1);
  for (int a = 0; a < 3; ++a)
    s.model.source.dims[a] = kBlobGrid;
  s.model.source.valueMin = s.grid.valueMin;
  s.model.source.valueMax = s.grid.valueMax;
  s.transfer = blobTransfer(s.grid.valueMin, s.grid.valueMax);
}

void makeStentScene(const nvbench::RawVolume& raw, Scene& s)
{
  s.name = "stent";
  s.grid = raw.view;
  s.model.initialize(1);
  for (int a = 0; a < 3; ++a)
    s.model.source.dims[a] = raw.view.dims[a];
  s.model.source.valueMin = raw.view.valueMin;
  s.model.source.valueMax = raw.view.valueMax;
  // Soft tissue transparent, contrast and stent opaque: opacity from 30 % of the range up.
  s.transfer = blobTransfer(raw.view.valueMin, raw.view.valueMax);
  for (size_t i = 0; i < s.transfer.rgba.size(); i += 4)
  {
    const float u = float(i / 4) / float(s.transfer.rgba.size() / 4 - 1);
    s.transfer.rgba[i + 3] = u < 0.3f ? 0.0f : 0.9f * std::min(1.0f, (u - 0.3f) / 0.3f);
  }
  s.transfer.unitDistance = 0.02;
}

/// The denoiser's time alone at larger sizes (1 path per pixel, the blob scene).
void timeDenoiser(ThreadPool& pool, const Scene& s)
{
  std::printf("\n### Denoiser time, CPU (%d threads), blob scene, PT, 1 path per pixel\n\n| size | pass ms | "
              "denoise ms | guide ms |\n|---|---|---|---|\n", pool.size());
  for (int size : { 256, 512 })
  {
    RenderRequest q = sceneRequest(s, ShadingMode::PathTrace, size);
    q.samplesPerPixel = 1;
    q.denoise = true;
    CpuRenderer r(pool);
    RenderResult res;
    r.render(s.model, 1, q, res);
    const double guide = res.stats.guideMilliseconds;
    r.render(s.model, 1, q, res);
    std::printf("| %d x %d | %.1f | %.1f | %.1f |\n", size, size, res.stats.renderMilliseconds,
      res.stats.denoiseMilliseconds, guide);
  }
}
} // namespace

int main(int argc, char** argv)
{
  int size = 64, referencePaths = 4096;
  std::string stent, ppm, cache;
  bool timing = true;
  for (int i = 1; i + 1 < argc; i += 2)
  {
    if (!std::strcmp(argv[i], "--size"))
      size = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--reference"))
      referencePaths = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--stent"))
      stent = argv[i + 1];
    else if (!std::strcmp(argv[i], "--ppm"))
      ppm = argv[i + 1];
    else if (!std::strcmp(argv[i], "--cache"))
      cache = argv[i + 1];
    else if (!std::strcmp(argv[i], "--timing"))
      timing = std::atoi(argv[i + 1]) != 0;
  }
  ThreadPool pool(2);
  std::printf("converged: PSNR >= %.0f dB against the reference\n", kConvergedDb);
  Scene blob;
  makeBlobScene(blob);
  for (ShadingMode mode : { ShadingMode::PathTrace, ShadingMode::PathTraceNee })
    measure(pool, blob, mode, size, referencePaths, ppm, cache);
  if (!stent.empty())
  {
    const nvbench::RawVolume raw = nvbench::loadNhdr(stent);
    Scene st;
    makeStentScene(raw, st);
    for (ShadingMode mode : { ShadingMode::PathTrace, ShadingMode::PathTraceNee })
      measure(pool, st, mode, size, referencePaths, ppm, cache);
  }
  if (timing)
    timeDenoiser(pool, blob);
  return 0;
}
