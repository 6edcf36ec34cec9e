// SessionOptions::cudaDevice (a GPU per MPI rank, issue 23) where it can be checked without a GPU: a device this
// process does not have falls back to the CPU under Device::Auto with the reason, is refused under Device::Cuda,
// and a negative ordinal other than -1 is refused on any device. The GPU side (a session on device 1 used from new
// threads, its memory on that device) is Testing/Gpu/TestDeviceOrdinal.cpp.
#include "Core/Engine.h"
#include "Core/NetworkSession.h"
#include "SessionHelpers.h"
#include "TestHarness.h"

#include <cmath>
#include <string>
#include <vector>

using namespace nv;

namespace
{
Model tinyModel()
{
  const std::vector<float> v = nvtest::sampledCube(8, [](double x, double y, double z) { return x + y * z; });
  const VolumeView vol = nvtest::cubeView(v, 8);
  return nvtest::untrainedModel(nvtest::smallModelConfig(10), vol, 3);
}
} // namespace

NV_TEST(MissingDeviceFallsBackUnderAuto)
{
  const int devices = cudaDeviceCount();
  EXPECT_TRUE(devices >= 0);
  SessionOptions options;
  options.cudaDevice = devices; // one past the last device this process sees
  std::string message;
  EXPECT_TRUE(resolveDevice(Device::Auto, &message, devices) == Device::Cpu);
  EXPECT_TRUE(message.find("running on the CPU") != std::string::npos);
  std::string why;
  EXPECT_TRUE(!cudaAvailable(&why, devices));
  EXPECT_TRUE(!why.empty());
  message.clear();
  auto session = NetworkSession::create(Device::Auto, tinyModel(), options, &message);
  EXPECT_TRUE(session->device() == Device::Cpu);
  EXPECT_TRUE(session->cudaDevice() == -1);
  EXPECT_TRUE(message.find("running on the CPU") != std::string::npos);
  // The CPU session works as any other: its output at the centre is the network's.
  const float centre[3] = { 0.5f, 0.5f, 0.5f };
  float out = std::nanf("");
  session->inferPoints(centre, 1, &out);
  EXPECT_TRUE(std::isfinite(out));
}

NV_TEST(MissingDeviceRefusedUnderCuda)
{
  const int devices = cudaDeviceCount();
  SessionOptions options;
  options.cudaDevice = devices;
  EXPECT_THROW_MSG(NetworkSession::create(Device::Cuda, tinyModel(), options), "not usable");
  EXPECT_THROW_MSG(resolveDevice(Device::Cuda, nullptr, devices), "not usable");
}

NV_TEST(NegativeOrdinalRefused)
{
  SessionOptions options;
  options.cudaDevice = -2;
  EXPECT_THROW_MSG(NetworkSession::create(Device::Cpu, tinyModel(), options), "cudaDevice");
  EXPECT_THROW_MSG(NetworkSession::create(Device::Auto, tinyModel(), options), "cudaDevice");
}

NV_TEST(CpuSessionHasNoCudaDevice)
{
  SessionOptions options;
  options.cudaDevice = 0; // ignored by the CPU backend
  auto session = NetworkSession::create(Device::Cpu, tinyModel(), options);
  EXPECT_TRUE(session->device() == Device::Cpu && session->cudaDevice() == -1);
}

NV_TEST_MAIN()
