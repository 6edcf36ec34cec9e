// NeuralVolume online benchmark: the Neural Compress filter's own training run (the engine's TrainingRun,
// Core/TrainingRun.h), as the GUI drives it -- training in a background thread that publishes to the session the
// renderer draws from.
//   nvBenchOnline DEVICE live FILE.nhdr LOG2T [seconds=2] [W=1280] [H=720]
//     -> training steps/s alone; for Decode and In-Shader ray marching, back to back and paced at 60 Hz: frames per
//        second, frames that showed a newer network, training steps/s meanwhile
//   nvBenchOnline DEVICE warm PREFIX FIRST COUNT LOG2T [coldSteps=1000] [batch=65536]
//     PREFIX_NN.nhdr for NN = FIRST .. FIRST+COUNT-1: per time step, the PSNR a cold start reaches in coldSteps steps
//     (the target), and the steps and seconds a cold and a warm start (from the previous step's network) need to reach
//     it (probe every 10 steps on 65536 voxels)
//   nvBenchOnline DEVICE restore FILE.nhdr LOG2T [steps=1000] [W=1280] [H=720]
//     -> serialized size; deserialize + session + first Decode frame (what a state restore does in the engine)
// Prints lines "RESULT {json}".
#include "Core/Error.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"
#include "Core/TrainingRun.h"
#include "Nhdr.h"
#include "RenderSetupBench.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

using namespace nv;
using Clock = std::chrono::steady_clock;

namespace
{
double seconds(Clock::time_point a)
{
  return std::chrono::duration<double>(Clock::now() - a).count();
}

RenderRequest anchorRequest(const nvbench::RawVolume& raw, RenderPath p, int w, int h, int frame)
{
  RenderRequest q;
  q.width = w;
  q.height = h;
  nvbench::anchorCamera(raw.view.dims, w, h, frame, q.viewProjection);
  nvbench::voxelWorldToUnit(raw.view.dims, q.worldToUnit);
  q.transfer = nvbench::anchorTransfer(raw.view.valueMin, raw.view.valueMax);
  q.path = p;
  q.shading = ShadingMode::RayMarch;
  q.sampleDistance = 1.0;
  return q;
}

std::shared_ptr<TrainingData> dataOf(const nvbench::RawVolume& raw, bool probe)
{
  auto d = std::make_shared<TrainingData>();
  d->Field.View = raw.view;
  if (probe)
    d->Probe.reset(new PsnrProbe(raw.view, 11, 65536));
  return d;
}

TrainConfig trainConfig(int batch)
{
  TrainConfig t;
  t.batchSize = batch;
  t.seed = 1;
  return t;
}

int live(Device device, const std::string& file, int log2T, double span, int w, int h)
{
  const nvbench::RawVolume raw = nvbench::loadVolume(file);
  auto d = dataOf(raw, false);
  {
    std::shared_ptr<NetworkSession> s = NetworkSession::create(device, nvbench::modelFor(raw, log2T, 1));
    RunLimits l;
    l.MaxSteps = 100000000;
    TrainingRun run(s, d, trainConfig(65536), l, nullptr);
    run.startInBackground();
    std::this_thread::sleep_for(std::chrono::milliseconds(300)); // trainer created, first chunks queued
    const int64_t s0 = run.status().Steps;
    const auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(span));
    const double rate = (run.status().Steps - s0) / seconds(t0);
    run.stop();
    std::printf("RESULT {\"what\":\"online_training_alone\",\"steps_per_s\":%.1f}\n", rate);
  }
  for (RenderPath p : { RenderPath::Decode, RenderPath::InShader })
    for (double pace : { 0.0, 1.0 / 60.0 })
    {
      std::shared_ptr<NetworkSession> s = NetworkSession::create(device, nvbench::modelFor(raw, log2T, 1));
      RunLimits l;
      l.MaxSteps = 100000000;
      l.PublishSeconds = 0.1; // the filter's default: the view shows a new network at least 10 times a second
      TrainingRun run(s, d, trainConfig(65536), l, nullptr);
      run.startInBackground();
      RenderResult image;
      for (int f = 0; f < 3; ++f)
        s->render(anchorRequest(raw, p, w, h, f), image, device == Device::Cuda ? Memory::Device : Memory::Host);
      std::vector<double> frame;
      int newer = 0;
      uint64_t last = s->version();
      const int64_t s0 = run.status().Steps;
      const auto t0 = Clock::now();
      for (int f = 0; seconds(t0) < span; ++f)
      {
        const auto t = Clock::now();
        s->render(anchorRequest(raw, p, w, h, f), image, device == Device::Cuda ? Memory::Device : Memory::Host);
        frame.push_back(seconds(t) * 1e3);
        const uint64_t v = s->version();
        newer += v != last ? 1 : 0;
        last = v;
        if (pace > 0.0)
          std::this_thread::sleep_until(t + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(pace)));
      }
      const double elapsed = seconds(t0);
      const double rate = (run.status().Steps - s0) / elapsed;
      run.stop();
      std::sort(frame.begin(), frame.end());
      std::printf("RESULT {\"what\":\"online_render_while_training\",\"path\":\"%s\",\"paced_hz\":%.0f,\"width\":%d,"
                  "\"height\":%d,\"frames\":%zu,\"fps\":%.1f,\"ms_median\":%.3f,\"ms_p95\":%.3f,"
                  "\"frames_with_newer_network\":%d,\"training_steps_per_s\":%.1f}\n",
        renderPathName(p), pace > 0 ? 1.0 / pace : 0.0, w, h, frame.size(), frame.size() / elapsed,
        frame[frame.size() / 2], frame[frame.size() * 95 / 100], newer, rate);
    }
  return 0;
}

/// Steps and seconds of a run until its probe reaches `target` (limit `maxSteps`).
void toTarget(std::shared_ptr<NetworkSession> s, const nvbench::RawVolume& raw, double target, int64_t maxSteps,
  int batch, int64_t& steps, double& secs, double& psnr)
{
  RunLimits l;
  l.MaxSteps = maxSteps;
  l.TargetPsnr = target;
  l.PsnrInterval = 10;
  TrainingRun run(s, dataOf(raw, true), trainConfig(batch), l, nullptr);
  run.runHere(nullptr, nullptr);
  steps = run.status().Steps;
  secs = run.status().Seconds;
  psnr = run.status().EndReason == "target PSNR" ? run.status().Psnr : compareToSource(*s, raw.view).psnr;
}

int warm(Device device, const std::string& prefix, int first, int count, int log2T, int coldSteps, int batch)
{
  std::vector<float> previous;
  for (int k = first; k < first + count; ++k)
  {
    char name[64];
    std::snprintf(name, sizeof(name), "_%02d.nhdr", k);
    const nvbench::RawVolume raw = nvbench::loadVolume(prefix + name);
    // The target: what a cold start reaches in coldSteps steps (probe estimate, same probe for both starts).
    std::shared_ptr<NetworkSession> cold = NetworkSession::create(device, nvbench::modelFor(raw, log2T, 1));
    double coldTime = 0.0, coldPsnr = 0.0;
    int64_t coldDone = 0;
    {
      RunLimits l;
      l.MaxSteps = coldSteps;
      TrainingRun run(cold, dataOf(raw, false), trainConfig(batch), l, nullptr);
      run.runHere(nullptr, nullptr);
      coldDone = run.status().Steps;
      coldTime = run.status().Seconds;
      coldPsnr = PsnrProbe(raw.view, 11, 65536).estimate(*cold);
    }
    if (!previous.empty())
    {
      Model seeded = nvbench::modelFor(raw, log2T, 1);
      seeded.params() = previous;
      std::shared_ptr<NetworkSession> w = NetworkSession::create(device, seeded);
      int64_t warmSteps = 0;
      double warmTime = 0.0, warmPsnr = 0.0;
      const double atStart = PsnrProbe(raw.view, 11, 65536).estimate(*w);
      toTarget(w, raw, coldPsnr, 4 * coldSteps, batch, warmSteps, warmTime, warmPsnr);
      // The cold start to the same target (probe every 10 steps), for the steps it needs.
      std::shared_ptr<NetworkSession> c2 = NetworkSession::create(device, nvbench::modelFor(raw, log2T, 1));
      int64_t coldToTarget = 0;
      double coldToTargetTime = 0.0, c2Psnr = 0.0;
      toTarget(c2, raw, coldPsnr, 4 * coldSteps, batch, coldToTarget, coldToTargetTime, c2Psnr);
      std::printf("RESULT {\"what\":\"warm_start\",\"file\":\"%s\",\"dims\":[%lld,%lld,%lld],\"target_psnr\":%.3f,"
                  "\"cold_steps\":%lld,\"cold_seconds\":%.4f,\"warm_steps\":%lld,\"warm_seconds\":%.4f,"
                  "\"warm_psnr_before_training\":%.3f,\"warm_reached\":%.3f,\"cold_reached\":%.3f}\n",
        raw.name.c_str(), (long long)raw.view.dims[0], (long long)raw.view.dims[1], (long long)raw.view.dims[2],
        coldPsnr, (long long)coldToTarget, coldToTargetTime, (long long)warmSteps, warmTime, atStart, warmPsnr,
        c2Psnr);
      previous = w->currentModel().params();
    }
    else
    {
      std::printf("RESULT {\"what\":\"warm_start_first\",\"file\":\"%s\",\"cold_psnr\":%.3f,\"steps\":%lld,"
                  "\"seconds\":%.4f}\n", raw.name.c_str(), coldPsnr, (long long)coldDone, coldTime);
      previous = cold->currentModel().params();
    }
  }
  return 0;
}

int restore(Device device, const std::string& file, int log2T, int steps, int w, int h)
{
  const nvbench::RawVolume raw = nvbench::loadVolume(file);
  std::vector<uint8_t> bytes;
  {
    std::shared_ptr<NetworkSession> s = NetworkSession::create(device, nvbench::modelFor(raw, log2T, 1));
    RunLimits l;
    l.MaxSteps = steps;
    TrainingRun run(s, dataOf(raw, false), trainConfig(65536), l, nullptr);
    run.runHere(nullptr, nullptr);
    Model m = s->currentModel();
    m.quantize(Precision::Float16);
    bytes = serialize(m);
  }
  for (int rep = 0; rep < 3; ++rep)
  {
    const auto t0 = Clock::now();
    const Model m = deserialize(bytes);
    const double tDeserialize = seconds(t0);
    std::unique_ptr<NetworkSession> s = NetworkSession::create(device, m);
    const double tSession = seconds(t0);
    RenderResult image;
    s->render(anchorRequest(raw, RenderPath::Decode, w, h, 0), image, Memory::Host);
    const double tFrame = seconds(t0);
    std::printf("RESULT {\"what\":\"restore\",\"file\":\"%s\",\"dims\":[%lld,%lld,%lld],\"bytes\":%zu,"
                "\"deserialize_ms\":%.2f,\"session_ms\":%.2f,\"first_decode_frame_ms\":%.2f,\"rep\":%d}\n",
      raw.name.c_str(), (long long)raw.view.dims[0], (long long)raw.view.dims[1], (long long)raw.view.dims[2],
      bytes.size(), tDeserialize * 1e3, tSession * 1e3, tFrame * 1e3, rep);
  }
  return 0;
}
} // namespace

int main(int argc, char** argv)
{
  if (argc < 4)
  {
    std::fprintf(stderr, "usage: see the head of OnlineBench.cpp\n");
    return 2;
  }
  try
  {
    const Device device = std::string(argv[1]) == "cpu" ? Device::Cpu : Device::Cuda;
    const std::string what = argv[2];
    auto arg = [&](int i, double dflt) { return argc > i ? std::atof(argv[i]) : dflt; };
    if (what == "live")
      return live(device, argv[3], int(arg(4, 16)), arg(5, 2.0), int(arg(6, 1280)), int(arg(7, 720)));
    if (what == "warm")
      return warm(device, argv[3], int(arg(4, 0)), int(arg(5, 2)), int(arg(6, 16)), int(arg(7, 1000)),
        int(arg(8, 65536)));
    if (what == "restore")
      return restore(device, argv[3], int(arg(4, 16)), int(arg(5, 1000)), int(arg(6, 1280)), int(arg(7, 720)));
    std::fprintf(stderr, "unknown benchmark %s\n", what.c_str());
    return 2;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
