// NeuralVolume engine: GlImageTarget through CUDA's OpenGL interop (cudaGraphicsGLRegisterImage).
#include "Core/GlImageTarget.h"

#include "GpuCommon.cuh"
#include "GpuEngine.h"

#include <cuda_gl_interop.h>

#include <sstream>

namespace nv
{
namespace gpu
{
namespace
{

constexpr size_t kPixelBytes = 4 * sizeof(float);

/// The CUDA device of the current OpenGL context; throws when the context runs on no GPU that CUDA sees.
int glContextDevice()
{
  unsigned int count = 0;
  int devices[4] = { -1, -1, -1, -1 };
  const cudaError_t e = cudaGLGetDevices(&count, devices, 4, cudaGLDeviceListAll);
  if (e != cudaSuccess || count == 0)
  {
    cudaGetLastError(); // not sticky: clear it
    std::ostringstream os;
    os << "the OpenGL context does not run on an NVIDIA GPU that CUDA can use ("
       << (e != cudaSuccess ? cudaGetErrorString(e) : "no CUDA device drives it") << ")";
    NV_THROW(os.str());
  }
  return devices[0];
}

class GpuGlImageTarget final : public GlImageTarget
{
public:
  GpuGlImageTarget(unsigned int texture, int width, int height)
    : Texture(texture)
    , Width(width)
    , Height(height)
  {
    NV_CHECK(texture != 0 && width > 0 && height > 0, "GlImageTarget: a texture and a size are needed");
    Device = glContextDevice();
    NV_CUDA(cudaSetDevice(Device));
    const cudaError_t e =
      cudaGraphicsGLRegisterImage(&Resource, texture, GL_TEXTURE_2D, cudaGraphicsRegisterFlagsNone);
    if (e != cudaSuccess)
    {
      cudaGetLastError();
      NV_THROW(std::string("CUDA cannot register the OpenGL texture: ") + cudaGetErrorString(e));
    }
  }

  ~GpuGlImageTarget() override
  {
    if (Resource)
      cudaGraphicsUnregisterResource(Resource); // nothing may leave a destructor
  }

  unsigned int texture() const override { return Texture; }
  int width() const override { return Width; }
  int height() const override { return Height; }

  void write(const float* deviceRgba) override
  {
    NV_CHECK(deviceRgba != nullptr, "GlImageTarget::write: no image");
    cudaPointerAttributes attributes{};
    NV_CUDA(cudaPointerGetAttributes(&attributes, deviceRgba));
    NV_CHECK(attributes.type == cudaMemoryTypeDevice && attributes.device == Device,
      "GlImageTarget::write: the image is not in the memory of the GPU that runs the OpenGL context");
    const size_t row = static_cast<size_t>(Width) * kPixelBytes;
    Mapped mapped(Resource);
    NV_CUDA(cudaMemcpy2DToArray(mapped.array, 0, 0, deviceRgba, row, row, static_cast<size_t>(Height),
      cudaMemcpyDeviceToDevice));
  }

  void read(std::vector<float>& rgba) override
  {
    const size_t row = static_cast<size_t>(Width) * kPixelBytes;
    rgba.resize(static_cast<size_t>(Width) * static_cast<size_t>(Height) * 4);
    Mapped mapped(Resource);
    NV_CUDA(cudaMemcpy2DFromArray(rgba.data(), row, mapped.array, 0, 0, row, static_cast<size_t>(Height),
      cudaMemcpyDeviceToHost));
  }

private:
  /// The texture mapped for CUDA while it lives (OpenGL must not touch it meanwhile); unmapped on every exit.
  struct Mapped
  {
    explicit Mapped(cudaGraphicsResource_t r)
      : resource(r)
    {
      NV_CUDA(cudaGraphicsMapResources(1, &resource, 0));
      const cudaError_t e = cudaGraphicsSubResourceGetMappedArray(&array, resource, 0, 0);
      if (e != cudaSuccess)
      {
        cudaGraphicsUnmapResources(1, &resource, 0);
        throwCuda(e, "cudaGraphicsSubResourceGetMappedArray", __FILE__, __LINE__);
      }
    }
    ~Mapped() { cudaGraphicsUnmapResources(1, &resource, 0); }
    Mapped(const Mapped&) = delete;
    Mapped& operator=(const Mapped&) = delete;
    cudaGraphicsResource_t resource;
    cudaArray_t array = nullptr;
  };

  unsigned int Texture;
  int Width;
  int Height;
  int Device = -1;
  cudaGraphicsResource_t Resource = nullptr;
};

} // namespace
} // namespace gpu

std::unique_ptr<GlImageTarget> GlImageTarget::create(unsigned int texture, int width, int height)
{
  std::string why;
  if (!gpu::deviceUsable(&why))
    NV_THROW("no GPU for CUDA-OpenGL interop: " + why);
  return std::unique_ptr<GlImageTarget>(new gpu::GpuGlImageTarget(texture, width, height));
}

} // namespace nv
