// NeuralVolume render benchmark (CPU or CUDA through the same session API), on the rendering anchor's setup
// (RenderSetupBench.h): a volume trained for STEPS steps, then frames of the anchor's orbit. The volume may be
// given as file.nhdr@2x: resampled to twice its resolution (a larger dataset with the same content).
//   nvBenchRender DEVICE file.nhdr LOG2T STEPS W H [paths] [modes] [frames] [outdir] [K]
//     paths: comma list of decode,stream,inshader (default all); modes: rm,grad,shadow,pt,nee (default all)
//     -> per path x mode: median ms per frame, FPS, samples evaluated vs a plain marcher, inference rate
//   nvBenchRender DEVICE file.nhdr LOG2T STEPS W H sweep [frames]   -> Sample Streaming K sweep (ray marching)
//   nvBenchRender DEVICE file.nhdr LOG2T STEPS W H skip [frames]    -> samples and time with skipping on / off
//   nvBenchRender DEVICE file.nhdr LOG2T STEPS W H train [seconds]  -> decode / in-shader ray marching while training
// Kernel variants: flags of KernelFlags.h. Prints lines "RESULT {json}"; with outdir, frame 0 of each
// combination is written there as a PPM.
#include "Core/NetworkSession.h"
#include "KernelFlags.h"
#include "Nhdr.h"
#include "RenderSetupBench.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace nv;
using Clock = std::chrono::steady_clock;

namespace
{
double ms(Clock::time_point a, Clock::time_point b)
{
  return std::chrono::duration<double, std::milli>(b - a).count();
}

std::vector<std::string> split(const std::string& s)
{
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    out.push_back(item);
  return out;
}

RenderPath parsePath(const std::string& s)
{
  return s == "decode" ? RenderPath::Decode : s == "stream" ? RenderPath::SampleStreaming : RenderPath::InShader;
}

ShadingMode parseMode(const std::string& s)
{
  if (s == "grad")
    return ShadingMode::RayMarchGradient;
  if (s == "shadow")
    return ShadingMode::RayMarchShadows;
  if (s == "pt")
    return ShadingMode::PathTrace;
  if (s == "nee")
    return ShadingMode::PathTraceNee;
  return ShadingMode::RayMarch;
}

void writePpm(const std::string& path, const std::vector<float>& rgba, int w, int h)
{
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f)
    return;
  std::fprintf(f, "P6\n%d %d\n255\n", w, h);
  std::vector<unsigned char> row(size_t(w) * 3);
  for (int y = h - 1; y >= 0; --y) // row 0 of the image is the bottom
  {
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
      {
        // over a black background
        const float v = rgba[(size_t(y) * w + x) * 4 + c];
        row[size_t(x) * 3 + c] = static_cast<unsigned char>(std::min(255.0f, std::max(0.0f, v * 255.0f + 0.5f)));
      }
    std::fwrite(row.data(), 1, row.size(), f);
  }
  std::fclose(f);
}

struct Bench
{
  NetworkSession* session;
  nvbench::RawVolume* raw;
  Memory where;
  int width, height;

  RenderRequest request(RenderPath p, ShadingMode m, int frame) const
  {
    RenderRequest q;
    q.width = width;
    q.height = height;
    nvbench::anchorCamera(raw->view.dims, width, height, frame, q.viewProjection);
    nvbench::voxelWorldToUnit(raw->view.dims, q.worldToUnit);
    q.transfer = nvbench::anchorTransfer(raw->view.valueMin, raw->view.valueMax);
    q.path = p;
    q.shading = m;
    q.sampleDistance = 1.0;
    q.lightDirection[0] = 0.3;
    q.lightDirection[1] = 0.4;
    q.lightDirection[2] = 0.87;
    return q;
  }

  /// Median over `frames` frames of the orbit (after two warm-up frames).
  void run(RenderPath p, ShadingMode m, int frames, const std::string& label, const std::string& outdir,
    const RenderRequest* base = nullptr)
  {
    std::vector<double> wall, gpu;
    double evaluated = 0, plain = 0, wavefronts = 0, hostSyncs = 0;
    RenderResult r;
    for (int f = -2; f < frames; ++f)
    {
      RenderRequest q = request(p, m, std::max(f, 0) + (f < 0 ? 1 : 0));
      if (base)
      {
        q.streamingSamples = base->streamingSamples;
        q.emptySpaceSkipping = base->emptySpaceSkipping;
      }
      const auto a = Clock::now();
      session->render(q, r, where);
      const auto b = Clock::now();
      if (f < 0)
        continue;
      wall.push_back(ms(a, b));
      gpu.push_back(r.stats.renderMilliseconds);
      evaluated += double(r.stats.samplesEvaluated);
      plain += double(r.stats.samplesPlain);
      wavefronts += double(r.stats.wavefronts);
      hostSyncs += double(r.stats.wavefrontHostSyncs);
      if (f == 0 && !outdir.empty())
      {
        if (where == Memory::Device)
          session->render(q, r, Memory::Host); // same request: returns the same image (reused or re-rendered)
        writePpm(outdir + "/" + label + ".ppm", r.rgba, width, height);
      }
    }
    // The image into host memory (what a caller without CUDA-GL interop pays): the last request again, which the
    // session returns without rendering (ray marching), so only the copy is timed.
    double copyMs = 0.0;
    if (where == Memory::Device && m < ShadingMode::PathTrace)
    {
      RenderRequest q = request(p, m, frames - 1);
      if (base)
      {
        q.streamingSamples = base->streamingSamples;
        q.emptySpaceSkipping = base->emptySpaceSkipping;
      }
      std::vector<double> c;
      for (int k = 0; k < 5; ++k)
      {
        const auto a = Clock::now();
        session->render(q, r, Memory::Host);
        c.push_back(ms(a, Clock::now()));
      }
      std::sort(c.begin(), c.end());
      copyMs = c[c.size() / 2];
    }
    std::sort(wall.begin(), wall.end());
    std::sort(gpu.begin(), gpu.end());
    const double w = wall[wall.size() / 2], g = gpu[gpu.size() / 2];
    const double ev = evaluated / frames, pl = plain / frames;
    std::printf("RESULT {\"what\":\"render\",\"label\":\"%s\",\"device\":\"%s\",\"path\":\"%s\",\"mode\":\"%s\","
                "\"width\":%d,\"height\":%d,\"K\":%d,\"skipping\":%d,\"frames\":%d,\"ms_wall\":%.3f,\"ms_render\":%.3f,"
                "\"fps_wall\":%.1f,\"samples_evaluated\":%.4g,\"samples_plain\":%.4g,\"plain_over_evaluated\":%.2f,"
                "\"wavefronts\":%.1f,\"wavefront_host_syncs\":%.1f,\"samples_per_s\":%.4g,\"ms_copy_to_host\":%.3f}\n",
      label.c_str(), deviceName(session->device()), renderPathName(p), shadingModeName(m), width, height,
      base ? base->streamingSamples : 0, base ? int(base->emptySpaceSkipping) : 1, frames, w, g, 1000.0 / w, ev, pl,
      ev > 0 ? pl / ev : 0.0, wavefronts / frames, hostSyncs / frames, ev / (g * 1e-3), copyMs);
    std::fflush(stdout);
  }
};
} // namespace

int main(int argc, char** argv)
{
  SessionOptions options;
  options.kernels = nvbench::parseKernelFlags(argc, argv);
  if (argc < 7)
  {
    std::fprintf(stderr, "usage: see the header of nvBenchRender.cpp\n");
    return 2;
  }
  try
  {
    const Device dev = std::string(argv[1]) == "cuda" ? Device::Cuda : Device::Cpu;
    nvbench::RawVolume raw = nvbench::loadVolume(argv[2]);
    const int log2T = std::atoi(argv[3]);
    const int steps = std::atoi(argv[4]);
    const int W = std::atoi(argv[5]), H = std::atoi(argv[6]);
    const std::string what = argc > 7 ? argv[7] : "";
    Model m = nvbench::modelFor(raw, log2T, 1);
    auto session = NetworkSession::create(dev, m, options);
    TrainConfig tc;
    tc.batchSize = 65536;
    auto trainer = session->createTrainer(raw.view, tc);
    const auto t0 = Clock::now();
    trainer->steps(steps, nullptr);
    trainer->publish();
    const double trainMs = ms(t0, Clock::now());
    const ErrorStats e = compareToSource(*session, raw.view);
    std::printf("RESULT {\"what\":\"trained\",\"name\":\"%s\",\"device\":\"%s\",\"steps\":%d,\"ms\":%.1f,\"psnr\":%.2f}\n",
      raw.name.c_str(), deviceName(dev), steps, trainMs, e.psnr);
    Bench b{ session.get(), &raw, dev == Device::Cuda ? Memory::Device : Memory::Host, W, H };

    if (what == "sweep")
    {
      const int frames = argc > 8 ? std::atoi(argv[8]) : 20;
      for (int K : { 1, 2, 4, 8, 16, 32, 64 })
      {
        RenderRequest base;
        base.streamingSamples = K;
        b.run(RenderPath::SampleStreaming, ShadingMode::RayMarch, frames, "sweep_K" + std::to_string(K), "", &base);
      }
      return 0;
    }
    if (what == "skip")
    {
      const int frames = argc > 8 ? std::atoi(argv[8]) : 20;
      for (RenderPath p : { RenderPath::Decode, RenderPath::InShader })
        for (bool skip : { true, false })
        {
          RenderRequest base;
          base.emptySpaceSkipping = skip;
          b.run(p, ShadingMode::RayMarch, frames, std::string(renderPathName(p)) + (skip ? " skip" : " noskip"), "",
            &base);
        }
      return 0;
    }
    if (what == "train")
    {
      // Training alone, then rendering (orbit frames, 2 s) while a second thread trains the same session: chunks of
      // 64 queued steps, each published to the session (the renderer sees every new network).
      const double seconds = argc > 8 ? std::atof(argv[8]) : 2.0;
      {
        const auto a = Clock::now();
        int64_t done = 0;
        while (ms(a, Clock::now()) < 1000.0 * seconds)
        {
          trainer->steps(64, nullptr);
          trainer->publish();
          done += 64;
        }
        std::printf("RESULT {\"what\":\"training_alone\",\"steps_per_s\":%.1f}\n", done / (ms(a, Clock::now()) * 1e-3));
      }
      for (RenderPath p : { RenderPath::Decode, RenderPath::InShader })
        for (double pace : { 0.0, 1000.0 / 60.0 }) // back to back; a frame every 1/60 s, as an interactive view
      {
        std::atomic<bool> stop{ false };
        std::atomic<int64_t> done{ 0 };
        std::thread worker([&] {
          while (!stop.load())
          {
            trainer->steps(64, nullptr);
            trainer->publish();
            done += 64;
          }
        });
        std::vector<double> frame;
        int64_t versions = 0;
        uint64_t last = session->version();
        RenderResult r;
        const auto a = Clock::now();
        for (int f = 0; ms(a, Clock::now()) < 1000.0 * seconds; ++f)
        {
          const auto t = Clock::now();
          session->render(b.request(p, ShadingMode::RayMarch, f), r, Memory::Device);
          frame.push_back(ms(t, Clock::now()));
          if (pace > 0.0)
            std::this_thread::sleep_until(t + std::chrono::microseconds(static_cast<int64_t>(pace * 1000.0)));
          const uint64_t v = session->version();
          versions += v != last ? 1 : 0;
          last = v;
        }
        const double elapsed = ms(a, Clock::now());
        stop = true;
        worker.join();
        std::sort(frame.begin(), frame.end());
        std::printf("RESULT {\"what\":\"render_while_training\",\"path\":\"%s\",\"paced_ms\":%.1f,\"width\":%d,\"height\":%d,"
                    "\"frames\":%zu,\"fps\":%.1f,\"ms_median\":%.3f,\"ms_p95\":%.3f,\"frames_with_new_network\":%lld,"
                    "\"training_steps_per_s\":%.1f}\n",
          renderPathName(p), pace, W, H, frame.size(), frame.size() / (elapsed * 1e-3), frame[frame.size() / 2],
          frame[frame.size() * 95 / 100], (long long)versions, done.load() / (elapsed * 1e-3));
      }
      return 0;
    }
    const std::vector<std::string> paths = split(argc > 7 && what.size() ? what : "decode,stream,inshader");
    const std::vector<std::string> modes = split(argc > 8 ? argv[8] : "rm,grad,shadow,pt,nee");
    const int frames = argc > 9 ? std::atoi(argv[9]) : 20;
    const std::string outdir = argc > 10 && std::string(argv[10]) != "-" ? argv[10] : "";
    RenderRequest base;
    base.streamingSamples = argc > 11 ? std::atoi(argv[11]) : 0;
    for (const std::string& p : paths)
      for (const std::string& md : modes)
        b.run(parsePath(p), parseMode(md), frames, p + "_" + md, outdir, &base);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
