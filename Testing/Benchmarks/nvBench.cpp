// NeuralVolume engine benchmark (CPU or CUDA through the same API).
//   nvBench step  DEVICE BATCH LOG2T FINEST [STEPS]      -> ms per training step, samples/s
//   nvBench infer DEVICE N LOG2T FINEST                  -> inference samples/s
//   nvBench curve DEVICE file.nhdr LOG2T STEPS[,..] [BATCH] [SEED] -> PSNR over all voxels at the given steps
//   nvBench decode DEVICE NX LOG2T FINEST                -> decode of an NX^3 grid
//   nvBench budget DEVICE file.nhdr LOG2T SECONDS BATCH  -> PSNR after training for a wall-clock budget
//   nvBench render PATH MODE W H [file.nhdr] [options]   -> CPU renderer frame times (RenderBench.cpp)
//   nvBench tradeoff DEVICE file.nhdr LOG2T STEPS[,..] [options] -> time vs error of a stored network (TradeoffBench.cpp;
//     learning-rate options --lr --decay --decay-interval --decay-factor --warmup --eps --beta2 --plateau --schedule
//     --planned --final)
// DEVICE: cpu | cuda. Kernel variants: flags of KernelFlags.h; --deterministic: TrainConfig::deterministic (step,
// budget, curve); --points=PREFIX (curve): also the PSNR at the points of PREFIX.points.f32 (network coordinates,
// float32 x 3) against PREFIX.values.f64 (a resampled source's own samples, anydataset_bench.py); --bank=PREFIX
// (curve): train from the bank of probed points PREFIX.bank.f32 (x y z in network coordinates and the value in
// source units, float32 x 4; Neural Compress's Sampling Probe) instead of the volume; --threads=N: CPU worker threads
// (SessionOptions::threads, 0 = all cores). Prints lines "RESULT {json}".
#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "KernelFlags.h"
#include "Nhdr.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <cstring>
#include <stdexcept>
#include <vector>

using namespace nv;
using Clock = std::chrono::steady_clock;

static double seconds(Clock::time_point a, Clock::time_point b)
{
  return std::chrono::duration<double>(b - a).count();
}

static Device parseDevice(const std::string& s)
{
  return s == "cuda" ? Device::Cuda : Device::Cpu;
}

static std::vector<float> analytic(int n)
{
  std::vector<float> v(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        v[(size_t(z) * n + y) * n + x] = float(std::sin(0.2 * x) * std::cos(0.13 * y) + std::sin(0.07 * z * x / n));
  return v;
}

int renderBenchmark(int argc, char** argv);
int tradeoffBenchmark(int argc, char** argv);

int main(int argc, char** argv)
{
  if (argc > 1 && (std::string(argv[1]) == "render" || std::string(argv[1]) == "tradeoff"))
  {
    try
    {
      return std::string(argv[1]) == "render" ? renderBenchmark(argc, argv) : tradeoffBenchmark(argc, argv);
    }
    catch (const std::exception& e)
    {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 1;
    }
  }
  SessionOptions options;
  options.kernels = nvbench::parseKernelFlags(argc, argv);
  bool deterministic = false;
  std::string pointsPrefix, bankPrefix;
  {
    int out = 1;
    for (int i = 1; i < argc; ++i)
    {
      if (std::string(argv[i]).rfind("--points=", 0) == 0)
        pointsPrefix = std::string(argv[i]).substr(9);
      else if (std::string(argv[i]).rfind("--bank=", 0) == 0)
        bankPrefix = std::string(argv[i]).substr(7);
      else if (std::string(argv[i]) == "--deterministic")
        deterministic = true;
      else if (std::string(argv[i]).rfind("--threads=", 0) == 0)
        options.threads = std::atoi(argv[i] + 10);
      else
        argv[out++] = argv[i];
    }
    argc = out;
  }
  if (argc < 3)
  {
    std::fprintf(stderr, "usage: see the header of nvBench.cpp\n");
    return 2;
  }
  const std::string mode = argv[1];
  const Device dev = parseDevice(argv[2]);
  try
  {
    if (mode == "step" || mode == "infer" || mode == "decode")
    {
      const int64_t size = std::atoll(argv[3]);
      ModelConfig c;
      c.encoding.log2TableSize = argc > 4 ? std::atoi(argv[4]) : 19;
      c.encoding.finestResolution = argc > 5 ? std::atoi(argv[5]) : 4096;
      Model m(c);
      m.initialize(1);
      const int n = 128;
      const auto data = analytic(n);
      VolumeView vol;
      vol.data = data.data();
      vol.dims[0] = vol.dims[1] = vol.dims[2] = n;
      const VolumeStats st = computeStats(vol);
      vol.valueMin = st.min;
      vol.valueMax = st.max;
      m.source.valueMin = st.min;
      m.source.valueMax = st.max;
      const auto session = NetworkSession::create(dev, m, options);
      if (mode == "step")
      {
        TrainConfig tc;
        tc.batchSize = int(size);
        tc.deterministic = deterministic;
        const int steps = argc > 6 ? std::atoi(argv[6]) : 10;
        auto tr = session->createTrainer(vol, tc);
        tr->step();
        tr->step();
        std::vector<double> ts;
        for (int i = 0; i < steps; ++i)
        {
          const auto a = Clock::now();
          tr->step();
          ts.push_back(seconds(a, Clock::now()));
        }
        std::sort(ts.begin(), ts.end());
        const double med = ts[ts.size() / 2];
        // Back to back: `steps` queues them and reads the losses once (tiny-cuda-nn's benchmark loop does the same).
        const auto b = Clock::now();
        tr->steps(steps, nullptr);
        const double b2b = seconds(b, Clock::now()) / steps;
        std::printf("RESULT {\"what\":\"train_step\",\"device\":\"%s\",\"batch\":%lld,\"log2T\":%d,\"finest\":%d,"
                    "\"params\":%zu,\"ms_median\":%.3f,\"ms_min\":%.3f,\"ms_back_to_back\":%.3f,\"samples_per_s\":%.4g,"
                    "\"device_mem_MiB\":%.1f,\"deterministic\":%d}\n",
          deviceName(dev), (long long)size, c.encoding.log2TableSize, c.encoding.finestResolution, m.paramCount(),
          med * 1e3, ts.front() * 1e3, b2b * 1e3, double(size) / b2b, tr->deviceMemoryBytes() / 1048576.0,
          int(deterministic));
      }
      else if (mode == "infer")
      {
        std::vector<float> xyz(static_cast<size_t>(size) * 3), out(static_cast<size_t>(size));
        for (size_t i = 0; i < xyz.size(); ++i)
          xyz[i] = float((i * 2654435761ull) % 1000003) / 1000003.f;
        session->inferPoints(xyz.data(), size, out.data(), Memory::Host);
        const auto a = Clock::now();
        session->inferPoints(xyz.data(), size, out.data(), Memory::Host);
        const double t = seconds(a, Clock::now());
        std::printf("RESULT {\"what\":\"inference\",\"device\":\"%s\",\"n\":%lld,\"ms\":%.3f,\"samples_per_s\":%.4g,"
                    "\"note\":\"host arrays, transfers included\"}\n",
          deviceName(dev), (long long)size, t * 1e3, double(size) / t);
      }
      else
      {
        std::vector<float> out(size_t(size) * size * size);
        decodeGridValues(*session, size, size, size, 0, size, out.data());
        const auto a = Clock::now();
        decodeGridValues(*session, size, size, size, 0, size, out.data());
        const double t = seconds(a, Clock::now());
        std::printf("RESULT {\"what\":\"decode\",\"device\":\"%s\",\"grid\":%lld,\"ms\":%.3f,\"samples_per_s\":%.4g,"
                    "\"note\":\"to host memory\"}\n",
          deviceName(dev), (long long)size, t * 1e3, double(size * size * size) / t);
      }
      return 0;
    }
    if (mode == "budget")
    {
      const nvbench::RawVolume raw = nvbench::loadNhdr(argv[3]);
      Model m = nvbench::modelFor(raw, std::atoi(argv[4]), 1);
      const ModelConfig& c = m.config();
      const double budget = std::atof(argv[5]);
      TrainConfig tc;
      tc.batchSize = std::atoi(argv[6]);
      tc.deterministic = deterministic;
      const auto a = Clock::now();
      const auto session = NetworkSession::create(dev, m, options);
      auto tr = session->createTrainer(raw.view, tc);
      while (seconds(a, Clock::now()) < budget)
        tr->step();
      tr->syncTo(m);
      const double t = seconds(a, Clock::now());
      m.quantize(Precision::Float16);
      session->setModel(m);
      const ErrorStats e = compareToSource(*session, raw.view);
      std::printf("RESULT {\"what\":\"budget\",\"device\":\"%s\",\"name\":\"%s\",\"log2T\":%d,\"batch\":%d,"
                  "\"seconds\":%.2f,\"steps\":%lld,\"psnr_fp16\":%.2f,\"ratio_fp16\":%.2f}\n",
        deviceName(dev), raw.name.c_str(), c.encoding.log2TableSize, tc.batchSize, t, (long long)tr->stepsDone(),
        e.psnr, double(raw.view.bytes()) / double(m.parameterBytes()));
      return 0;
    }
    if (mode == "curve")
    {
      const nvbench::RawVolume raw = nvbench::loadNhdr(argv[3]);
      const int log2T = std::atoi(argv[4]);
      const std::vector<int> marks = nvbench::parseSteps(argv[5]);
      const uint64_t seed = argc > 7 ? std::strtoull(argv[7], nullptr, 10) : 1;
      Model m = nvbench::modelFor(raw, log2T, seed);
      const ModelConfig& c = m.config();
      TrainConfig tc;
      tc.seed = seed;
      tc.batchSize = argc > 6 ? std::atoi(argv[6]) : 65536;
      tc.deterministic = deterministic;
      const auto session = NetworkSession::create(dev, m, options);
      auto slurp = [](const std::string& path) {
        FILE* f = std::fopen(path.c_str(), "rb");
        if (!f)
          throw std::runtime_error("cannot open " + path);
        std::vector<char> b;
        char buf[65536];
        size_t k;
        while ((k = std::fread(buf, 1, sizeof buf, f)) > 0)
          b.insert(b.end(), buf, buf + k);
        std::fclose(f);
        return b;
      };
      std::vector<float> bankXyz, bankValues;
      std::unique_ptr<Trainer> tr;
      if (!bankPrefix.empty())
      {
        const std::vector<char> a = slurp(bankPrefix + ".bank.f32");
        const size_t n = a.size() / 16;
        const float* f = reinterpret_cast<const float*>(a.data());
        const double lo = raw.view.valueMin, range = raw.view.valueMax > lo ? raw.view.valueMax - lo : 1.0;
        for (size_t i = 0; i < n; ++i)
        {
          bankXyz.insert(bankXyz.end(), f + 4 * i, f + 4 * i + 3);
          bankValues.push_back(static_cast<float>((double(f[4 * i + 3]) - lo) / range));
        }
        TrainingPoints bank;
        bank.xyz = bankXyz.data();
        bank.values = bankValues.data();
        bank.count = int64_t(n);
        tr = session->createTrainer(bank, tc);
      }
      else
        tr = session->createTrainer(raw.view, tc);
      std::vector<float> pts;
      std::vector<double> vals;
      if (!pointsPrefix.empty())
      {
        const std::vector<char> a = slurp(pointsPrefix + ".points.f32"), b = slurp(pointsPrefix + ".values.f64");
        pts.resize(a.size() / 4);
        vals.resize(b.size() / 8);
        std::memcpy(pts.data(), a.data(), pts.size() * 4);
        std::memcpy(vals.data(), b.data(), vals.size() * 8);
        if (pts.size() != 3 * vals.size())
          throw std::runtime_error("points and values of " + pointsPrefix + " do not match");
      }
      // PSNR of the session's network at the source's own samples (values normalised by the trained range).
      auto pointsPsnr = [&]() {
        std::vector<float> out(vals.size());
        session->inferPoints(pts.data(), int64_t(vals.size()), out.data(), Memory::Host);
        const double lo = raw.view.valueMin, range = raw.view.valueMax > lo ? raw.view.valueMax - lo : 1.0;
        double se = 0.0;
        for (size_t i = 0; i < vals.size(); ++i)
        {
          const double v = lo + double(out[i]) * range;
          const double d = std::isfinite(v) ? (v - vals[i]) / range : INFINITY;
          se += d * d;
        }
        return 10.0 * std::log10(double(vals.size()) / se);
      };
      double trainTime = 0;
      std::printf("RESULT {\"what\":\"curve\",\"device\":\"%s\",\"name\":\"%s\",\"log2T\":%d,\"finest\":%d,"
                  "\"batch\":%d,\"deterministic\":%d,\"bank\":%lld,\"curve\":[", deviceName(dev), raw.name.c_str(), log2T,
        c.encoding.finestResolution, tc.batchSize, int(deterministic), (long long)bankValues.size());
      int done = 0;
      for (size_t k = 0; k < marks.size(); ++k)
      {
        const auto a = Clock::now();
        while (done < marks[k])
        {
          tr->step();
          ++done;
        }
        tr->publish();
        trainTime += seconds(a, Clock::now());
        const ErrorStats e = compareToSource(*session, raw.view);
        if (vals.empty())
          std::printf("%s[%d,%.2f,%.2f]", k ? "," : "", done, trainTime, e.psnr);
        else
          std::printf("%s[%d,%.2f,%.2f,%.2f]", k ? "," : "", done, trainTime, e.psnr, pointsPsnr());
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
