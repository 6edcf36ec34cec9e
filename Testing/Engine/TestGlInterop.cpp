// CUDA-OpenGL interop (nv::GlImageTarget) where it cannot work: a build without CUDA, or a machine without a usable
// GPU, refuses it with nv::Error saying why -- the caller (the Neural Volume mapper) then copies images through the
// host. Where a GPU is usable the interop itself is exercised inside ParaView (nv.pv.GpuParaView: the picture through
// interop equals the one through the host), which has the OpenGL context this test lacks.
#include "TestHarness.h"

#include "Core/Backends.h"
#include "Core/Error.h"
#include "Core/GlImageTarget.h"

#include <cstdio>
#include <string>

NV_TEST(refused_with_a_reason_without_a_gpu)
{
  std::string why;
  if (nv::cudaBackendUsable(&why))
  {
    std::printf("    a GPU is usable here: interop needs an OpenGL context (nv.pv.GpuParaView runs it)\n");
    return;
  }
  std::string message;
  try
  {
    nv::GlImageTarget::create(1, 16, 16);
  }
  catch (const nv::Error& e)
  {
    message = e.what();
  }
  std::printf("    %s\n", message.c_str());
  EXPECT_TRUE(message.find("CUDA") != std::string::npos);
  EXPECT_TRUE(message.find(why) != std::string::npos || message.find("no CUDA support") != std::string::npos);
}

NV_TEST_MAIN()
