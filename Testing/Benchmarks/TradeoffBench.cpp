// nvBench tradeoff: run time against error for one volume and table size (Testing/Benchmarks/tradeoff.py).
//   nvBench tradeoff DEVICE file.nhdr LOG2T STEPS[,..] [--batch=N] [--seed=N] [--threads=N] [--loss=l1|l2]
//                    [--lr=X] [--decay=step|none] [--decay-interval=N] [--decay-factor=X] [--warmup=N] [--eps=X]
//                    [--beta2=X] [--plateau=STEPS] [--schedule=step|exp|cos|auto] [--planned=STEPS]
//                    [--final=X] [--hold=STEPS]
//                    [--importance=CELLS] [--dump=DIR] [--storage=fp16|q8|both] [--qat=FRACTION]
// Trains the method's network (16x4 levels, finest 2x the largest dimension, 64x4 MLP, the filter's defaults) and, at
// each step count, stores it as Neural Compress does (fp16, or --storage), decodes the full grid and prints one line
//   RESULT {"what":"tradeoff", ... "storage", "steps", "train_s", "decode_s", "psnr", "max_error", "ratio", "model_bytes"}
// train_s: wall time of the training steps so far (setup excluded, the decode and the evaluation excluded); decode_s:
// one decode of the whole grid into host memory; psnr and max_error over every voxel (values normalised by the range;
// max_error in source units); ratio: source bytes / stored parameter bytes. --schedule: step (the default here, so that
// old logs compare: the paper's step decay), exp or cos (anneal the rate to --final, default 0.01, of --lr at --planned
// steps, default the last step count), auto (the engine's default for a run of known length). --dump writes the
// decoded grid (float32, source units, x fastest) to DIR/NAME_T<log2T>_S<steps>.f32 for the image metrics of the
// harness. --storage: how the network is stored at each mark (Neural Compress's StoragePrecision): fp16 (the
// default, so that old logs compare), q8 (8-bit codes, entropy coded: Precision::Quantized8) or both (one RESULT line
// per storage, fp16 first, from the same trained parameters); every line has "storage":"fp16" or "q8" (and the dump
// file name ends in _q8 for q8).
#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "Nhdr.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

using namespace nv;

namespace
{
using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point a, Clock::time_point b)
{
  return std::chrono::duration<double>(b - a).count();
}

bool option(const std::string& arg, const char* name, std::string& value)
{
  const std::string prefix = std::string("--") + name + "=";
  if (arg.rfind(prefix, 0) != 0)
    return false;
  value = arg.substr(prefix.size());
  return true;
}

std::string jsonNumber(double v)
{
  if (!std::isfinite(v))
    return "null";
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}
} // namespace

int tradeoffBenchmark(int argc, char** argv)
{
  std::vector<std::string> positional;
  TrainConfig tc;
  SessionOptions options;
  std::string dumpDir;
  bool plannedGiven = false;
  std::vector<Precision> storages = { Precision::Float16 };
  tc.optimizer.schedule = LearningRateSchedule::StepDecay;
  for (int i = 2; i < argc; ++i)
  {
    const std::string a = argv[i];
    std::string v;
    if (option(a, "batch", v))
      tc.batchSize = std::atoi(v.c_str());
    else if (option(a, "seed", v))
      tc.seed = std::strtoull(v.c_str(), nullptr, 10);
    else if (option(a, "threads", v))
      options.threads = tc.threads = std::atoi(v.c_str());
    else if (option(a, "loss", v))
      tc.loss = v == "l2" ? LossType::L2 : LossType::L1;
    else if (option(a, "lr", v))
      tc.optimizer.learningRate = std::atof(v.c_str());
    else if (option(a, "decay", v))
      tc.optimizer.stepDecay = v != "none";
    else if (option(a, "warmup", v))
      tc.optimizer.warmupSteps = std::atoi(v.c_str());
    else if (option(a, "plateau", v))
      tc.optimizer.plateauWindow = std::atoi(v.c_str());
    else if (option(a, "beta2", v))
      tc.optimizer.beta2 = std::atof(v.c_str());
    else if (option(a, "eps", v))
      tc.optimizer.epsilon = std::atof(v.c_str());
    else if (option(a, "decay-interval", v))
      tc.optimizer.decayInterval = std::atoi(v.c_str());
    else if (option(a, "decay-factor", v))
      tc.optimizer.decayFactor = std::atof(v.c_str());
    else if (option(a, "schedule", v))
    {
      if (v != "step" && v != "exp" && v != "cos" && v != "auto")
        throw std::runtime_error("--schedule must be step, exp, cos or auto");
      tc.optimizer.schedule = v == "exp" ? LearningRateSchedule::Exponential
        : v == "cos"                     ? LearningRateSchedule::Cosine
        : v == "auto"                    ? LearningRateSchedule::Auto
                                         : LearningRateSchedule::StepDecay;
    }
    else if (option(a, "planned", v))
    {
      tc.optimizer.plannedSteps = std::atof(v.c_str());
      plannedGiven = true;
    }
    else if (option(a, "final", v))
      tc.optimizer.finalRateFraction = std::atof(v.c_str());
    else if (option(a, "hold", v))
      tc.optimizer.holdSteps = std::atoi(v.c_str());
    else if (option(a, "qat", v))
      tc.quantizationAwareFraction = std::atof(v.c_str()); // TrainConfig::quantizationAwareFraction
    else if (option(a, "importance", v))
      tc.importanceGrid = std::atoi(v.c_str());
    else if (option(a, "dump", v))
      dumpDir = v;
    else if (option(a, "storage", v))
    {
      if (v != "fp16" && v != "q8" && v != "both")
        throw std::runtime_error("--storage must be fp16, q8 or both");
      storages = v == "fp16" ? std::vector<Precision>{ Precision::Float16 }
        : v == "q8"          ? std::vector<Precision>{ Precision::Quantized8 }
                             : std::vector<Precision>{ Precision::Float16, Precision::Quantized8 };
    }
    else
      positional.push_back(a);
  }
  if (positional.size() != 4)
    throw std::runtime_error("usage: nvBench tradeoff DEVICE file.nhdr LOG2T STEPS[,..] [options]");
  const Device dev = positional[0] == "cuda" ? Device::Cuda : Device::Cpu;
  const nvbench::RawVolume raw = nvbench::loadNhdr(positional[1]);
  const int log2T = std::atoi(positional[2].c_str());
  const std::vector<int> marks = nvbench::parseSteps(positional[3]);
  if (!plannedGiven && !marks.empty())
    tc.optimizer.plannedSteps = marks.back();
  Model m = nvbench::modelFor(raw, log2T, tc.seed);
  const auto session = NetworkSession::create(dev, m, options);
  Model stored = m;
  stored.quantize(storages.front());
  const auto evalSession = NetworkSession::create(dev, stored, options);
  auto tr = session->createTrainer(raw.view, tc);
  const int64_t nx = raw.view.dims[0], ny = raw.view.dims[1], nz = raw.view.dims[2];
  std::vector<float> decoded(size_t(nx * ny * nz));
  double trainTime = 0.0;
  int done = 0;
  for (const int mark : marks)
  {
    const auto a = Clock::now();
    while (done < mark)
    {
      tr->step();
      ++done;
    }
    tr->publish();
    trainTime += seconds(a, Clock::now());
    for (const Precision storage : storages)
    {
      tr->syncTo(stored);
      stored.quantize(storage);
      evalSession->setModel(stored);
      decodeGridValues(*evalSession, nx, ny, nz, 0, nz, decoded.data()); // warm (first use allocates)
      const auto d = Clock::now();
      decodeGridValues(*evalSession, nx, ny, nz, 0, nz, decoded.data());
      const double decodeTime = seconds(d, Clock::now());
      const ErrorStats e = compareDecoded(decoded.data(), raw.view, raw.view.valueMin, raw.view.valueMax);
      std::string dumped;
      if (!dumpDir.empty())
      {
        dumped = dumpDir + "/" + raw.name + "_T" + std::to_string(log2T) + "_S" + std::to_string(done) +
          (storage == Precision::Quantized8 ? "_q8" : "") + ".f32";
        FILE* f = std::fopen(dumped.c_str(), "wb");
        if (!f || std::fwrite(decoded.data(), sizeof(float), decoded.size(), f) != decoded.size())
          throw std::runtime_error("cannot write " + dumped);
        std::fclose(f);
      }
      std::printf("RESULT {\"what\":\"tradeoff\",\"device\":\"%s\",\"name\":\"%s\",\"dims\":[%lld,%lld,%lld],"
                  "\"log2T\":%d,\"batch\":%d,\"seed\":%llu,\"loss\":\"%s\",\"storage\":\"%s\",\"steps\":%d,"
                  "\"train_s\":%.4f,"
                  "\"decode_s\":%.5f,\"psnr\":%s,\"max_error\":%s,\"ratio\":%.4f,\"model_bytes\":%lld,"
                  "\"source_bytes\":%lld,\"qat\":%g,\"dump\":\"%s\"}\n",
        deviceName(dev), raw.name.c_str(), (long long)nx, (long long)ny, (long long)nz, log2T, tc.batchSize,
        (unsigned long long)tc.seed, tc.loss == LossType::L2 ? "l2" : "l1", precisionName(storage), done, trainTime,
        decodeTime,
        jsonNumber(e.psnr).c_str(), jsonNumber(e.maxAbsError).c_str(),
        double(raw.view.bytes()) / double(stored.parameterBytes()), (long long)stored.parameterBytes(),
        (long long)raw.view.bytes(), tc.quantizationAwareFraction, dumped.c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}
