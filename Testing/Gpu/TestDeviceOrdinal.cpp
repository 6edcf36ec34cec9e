// SessionOptions::cudaDevice on a machine with GPUs (issue 23: each MPI rank on the GPU of its local rank): a session
// made for device d runs there whatever thread calls it -- a new std::thread starts on device 0, as the filter's
// background training thread and ParaView's render thread do -- its memory is allocated on d and on no other device,
// and with Deterministic a network trained on any device of the same model is the same bits. With one GPU only
// device 0 is checked (the placement case then has nothing to compare); the lead's 2-GPU run checks device 1.
// Exits with 77 (SKIP_RETURN_CODE) when no usable GPU is present.
#include "BlockingTraining.h"
#include "Core/Backends.h"
#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "Core/PsnrProbe.h"
#include "Gpu/GpuEngine.h"
#include "TestHarness.h"
#include "TestVolumeView.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

using namespace nv;

namespace
{
constexpr int kSkip = 77;
constexpr int kN = 48;
constexpr int kMaxDevicesChecked = 8;

std::vector<float> smoothVolume(int n)
{
  std::vector<float> v(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        v[(size_t(z) * n + y) * n + x] = float(std::sin(0.21 * x) * std::cos(0.17 * y) + 0.4 * std::sin(0.13 * z));
  return v;
}

Model smallModel(const VolumeView& vol)
{
  ModelConfig c;
  c.encoding.log2TableSize = 14;
  c.encoding.finestResolution = 96;
  Model m(c);
  m.initialize(3);
  m.source.valueMin = vol.valueMin;
  m.source.valueMax = vol.valueMax;
  return m;
}

TrainConfig deterministicConfig()
{
  TrainConfig tc;
  tc.batchSize = 16384;
  tc.seed = 5;
  tc.deterministic = true;
  tc.strategy = TrainingStrategy::GpuResident;
  return tc;
}

int devicesToCheck()
{
  return std::min(cudaDeviceCount(), kMaxDevicesChecked);
}

SessionOptions onDevice(int d)
{
  SessionOptions o;
  o.cudaDevice = d;
  return o;
}

/// Trained on device d from a new thread (the filter's loop, nv::TrainingRun), then decoded from another new thread.
struct DeviceResult
{
  std::string description;
  int sessionDevice = -1;
  double psnr = 0.0;
  std::vector<float> decoded;
  std::string error;
};

DeviceResult trainOn(int d, const VolumeView& vol)
{
  DeviceResult r;
  auto session = NetworkSession::create(Device::Cuda, smallModel(vol), onDevice(d));
  r.sessionDevice = session->cudaDevice();
  r.description = gpu::deviceDescription(); // create() left device d current on this thread
  const PsnrProbe probe(vol, 7, 20000);
  std::thread training([&] {
    try
    {
      nvtest::TrainingRequest rq;
      rq.MaxSteps = 300;
      rq.PsnrInterval = 100;
      nvtest::trainHere(*session, vol, deterministicConfig(), rq, &probe);
    }
    catch (const std::exception& e)
    {
      r.error = e.what();
    }
  });
  training.join();
  std::thread reading([&] {
    try
    {
      r.psnr = probe.estimate(*session);
      r.decoded.resize(size_t(kN) * kN * kN);
      session->decodeGrid(kN, kN, kN, 0, kN, r.decoded.data());
    }
    catch (const std::exception& e)
    {
      r.error += e.what();
    }
  });
  reading.join();
  return r;
}
} // namespace

NV_TEST(every_device_trains_from_new_threads)
{
  const auto data = smoothVolume(kN);
  const VolumeView vol = floatCubeView(data, kN);
  std::vector<DeviceResult> results;
  for (int d = 0; d < devicesToCheck(); ++d)
  {
    results.push_back(trainOn(d, vol));
    const DeviceResult& r = results.back();
    std::printf("    device %d: %s, session device %d, %.3f dB%s%s\n", d, r.description.c_str(), r.sessionDevice, r.psnr,
      r.error.empty() ? "" : ", error: ", r.error.c_str());
    EXPECT_TRUE(r.error.empty());
    EXPECT_TRUE(r.sessionDevice == d);
    EXPECT_TRUE(r.psnr > 25.0);
    if (d > 0 && r.description == results[0].description && r.decoded.size() == results[0].decoded.size())
    {
      // Deterministic: the same model of GPU gives the same bits on every device.
      const bool same = std::memcmp(r.decoded.data(), results[0].decoded.data(), r.decoded.size() * sizeof(float)) == 0;
      std::printf("    device %d decodes bit for bit as device 0: %s\n", d, same ? "yes" : "no");
      EXPECT_TRUE(same);
    }
  }
}

NV_TEST(memory_lands_on_the_sessions_device)
{
  const int devices = devicesToCheck();
  // A 64 MiB field, uploaded by a GPU-resident trainer on the last device.
  constexpr int kBig = 256;
  const auto data = smoothVolume(kBig);
  const VolumeView vol = floatCubeView(data, kBig);
  std::vector<int64_t> before(size_t(devices), 0), after(size_t(devices), 0);
  int64_t total = 0;
  for (int d = 0; d < devices; ++d) // every device's context made first: only the trainer's allocations count
    EXPECT_TRUE(cudaDeviceMemory(before[size_t(d)], total, d));
  const int target = devices - 1;
  auto session = NetworkSession::create(Device::Cuda, smallModel(vol), onDevice(target));
  std::unique_ptr<Trainer> trainer;
  std::thread making([&] { trainer = session->createTrainer(vol, deterministicConfig()); });
  making.join();
  for (int d = 0; d < devices; ++d)
    EXPECT_TRUE(cudaDeviceMemory(after[size_t(d)], total, d));
  for (int d = 0; d < devices; ++d)
  {
    const double dropMiB = double(before[size_t(d)] - after[size_t(d)]) / 1048576.0;
    std::printf("    device %d: %.1f MiB less free after the trainer of device %d\n", d, dropMiB, target);
    if (d == target)
      EXPECT_TRUE(dropMiB >= double(vol.bytes()) / 1048576.0);
    else
      EXPECT_TRUE(dropMiB < 16.0);
  }
  std::thread stepping([&] {
    trainer->steps(10, nullptr);
    trainer->publish();
  });
  stepping.join();
  EXPECT_TRUE(trainer->stepsDone() == 10);
}

NV_TEST(missing_device_falls_back_to_the_cpu)
{
  const auto data = smoothVolume(16);
  const VolumeView vol = floatCubeView(data, 16);
  const int devices = cudaDeviceCount();
  std::string message;
  auto session = NetworkSession::create(Device::Auto, smallModel(vol), onDevice(devices), &message);
  EXPECT_TRUE(session->device() == Device::Cpu && session->cudaDevice() == -1);
  EXPECT_TRUE(message.find("no CUDA device " + std::to_string(devices)) != std::string::npos);
  EXPECT_THROW_MSG(NetworkSession::create(Device::Cuda, smallModel(vol), onDevice(devices)), "not usable");
}

int main(int argc, char** argv)
{
  std::string why;
  if (!cudaAvailable(&why))
  {
    std::printf("SKIP: %s\n", why.c_str());
    return kSkip;
  }
  std::printf("%d CUDA device(s)\n", cudaDeviceCount());
  return nvtest::runCases(argc, argv);
}
