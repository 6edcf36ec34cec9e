// NeuralVolume CUDA benchmark (figures that the device-agnostic nvBench cannot take).
//   nvBenchGpu infer N LOG2T FINEST    -> inference: kernel alone, session API on device arrays, on host arrays
//   nvBenchGpu decode NX LOG2T FINEST  -> decode of an NX^3 grid: kernel alone, session API to device / host memory
//   nvBenchGpu ttq file.nhdr LOG2T STEPS[,..] [BATCH]  -> wall time incl. trainer creation/upload and PSNR at marks
// Paper configuration otherwise (16 levels x 4, base 16, 64 x 4 MLP). Kernel variants: flags of KernelFlags.h.
// Prints lines "RESULT {json}".
#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "Gpu/GpuEngine.h"
#include "GpuTestHooks.h"
#include "KernelFlags.h"
#include "Nhdr.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

using namespace nv;
using Clock = std::chrono::steady_clock;

static double seconds(Clock::time_point a, Clock::time_point b)
{
  return std::chrono::duration<double>(b - a).count();
}

int main(int argc, char** argv)
{
  SessionOptions options;
  options.kernels = nvbench::parseKernelFlags(argc, argv);
  if (argc < 3)
  {
    std::fprintf(stderr, "usage: see the header of nvBenchGpu.cpp\n");
    return 2;
  }
  const std::string mode = argv[1];
  try
  {
    std::string why;
    if (!gpu::deviceUsable(&why))
    {
      std::fprintf(stderr, "no usable GPU: %s\n", why.c_str());
      return 77;
    }
    if (mode == "infer" || mode == "decode")
    {
      const int64_t size = std::atoll(argv[2]);
      ModelConfig c;
      c.encoding.log2TableSize = argc > 3 ? std::atoi(argv[3]) : 19;
      c.encoding.finestResolution = argc > 4 ? std::atoi(argv[4]) : 4096;
      Model m(c);
      m.initialize(1);
      for (size_t i = 0; i < m.encodingParamCount(); ++i) // O(0.1) table values, as after training
        m.params()[i] *= 1000.0f;
      const auto session = NetworkSession::create(Device::Cuda, m, options);
      if (mode == "infer")
      {
        const double ms = gpu::benchInferKernel(m, size, 20, options.kernels);
        const double api = gpu::benchSessionInfer(*session, size, 20);
        std::vector<float> xyz(static_cast<size_t>(size) * 3), out(static_cast<size_t>(size));
        for (size_t i = 0; i < xyz.size(); ++i)
          xyz[i] = float((i * 2654435761ull) % 1000003) / 1000003.f;
        session->inferPoints(xyz.data(), size, out.data(), Memory::Host);
        const auto a = Clock::now();
        session->inferPoints(xyz.data(), size, out.data(), Memory::Host);
        const double t = seconds(a, Clock::now());
        std::printf("RESULT {\"what\":\"inference\",\"n\":%lld,\"log2T\":%d,\"kernel_ms\":%.3f,"
                    "\"kernel_samples_per_s\":%.4g,\"api_device_ms\":%.3f,\"api_device_samples_per_s\":%.4g,"
                    "\"api_host_ms\":%.3f,\"api_host_samples_per_s\":%.4g}\n",
          (long long)size, c.encoding.log2TableSize, ms, double(size) / (ms * 1e-3), api, double(size) / (api * 1e-3),
          t * 1e3, double(size) / t);
      }
      else
      {
        const double ms = gpu::benchDecodeKernel(m, size, size, size, 5, options.kernels);
        const double api = gpu::benchSessionDecode(*session, size, size, size, 5);
        std::vector<float> out(size_t(size) * size * size);
        session->decodeGrid(size, size, size, 0, size, out.data(), Memory::Host);
        const auto a = Clock::now();
        session->decodeGrid(size, size, size, 0, size, out.data(), Memory::Host);
        const double t = seconds(a, Clock::now());
        const double n = double(size) * size * size;
        std::printf("RESULT {\"what\":\"decode\",\"grid\":%lld,\"kernel_ms\":%.3f,\"kernel_samples_per_s\":%.4g,"
                    "\"api_device_ms\":%.3f,\"api_host_ms\":%.3f,\"api_host_samples_per_s\":%.4g,"
                    "\"note\":\"api_device: session->decodeGrid into device memory; api_host: into host memory\"}\n",
          (long long)size, ms, n / (ms * 1e-3), api, t * 1e3, n / t);
      }
      return 0;
    }
    if (mode == "ttq")
    {
      const nvbench::RawVolume raw = nvbench::loadNhdr(argv[2]);
      const int log2T = std::atoi(argv[3]);
      const std::vector<int> marks = nvbench::parseSteps(argv[4]);
      Model m = nvbench::modelFor(raw, log2T, 1);
      const ModelConfig& c = m.config();
      TrainConfig tc;
      tc.batchSize = argc > 5 ? std::atoi(argv[5]) : 65536;
      const auto a = Clock::now();
      const auto session = NetworkSession::create(Device::Cuda, m, options);
      auto tr = session->createTrainer(raw.view, tc);
      double wall = seconds(a, Clock::now());
      const double create = wall;
      std::printf("RESULT {\"what\":\"time_to_quality\",\"name\":\"%s\",\"log2T\":%d,\"create_s\":%.4f,"
                  "\"device_mem_MiB\":%.1f,\"curve\":[",
        raw.name.c_str(), log2T, create, tr->deviceMemoryBytes() / 1048576.0);
      int done = 0;
      for (size_t k = 0; k < marks.size(); ++k)
      {
        const auto b = Clock::now();
        tr->steps(marks[k] - done, nullptr); // back to back, as Neural Compress runs them
        done = marks[k];
        tr->publish();
        wall += seconds(b, Clock::now());
        const ErrorStats e = compareToSource(*session, raw.view);
        std::printf("%s[%d,%.4f,%.2f]", k ? "," : "", done, wall, e.psnr);
        std::fflush(stdout);
      }
      std::printf("]}\n");
      return 0;
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "unknown mode %s\n", mode.c_str());
  return 2;
}
