// NeuralVolume engine: GlImageTarget through CUDA's OpenGL interop (cudaGraphicsGLRegisterImage).
#include "Core/GlImageTarget.h"

#include "GpuCommon.cuh"
#include "GpuEngine.h"

#include <cuda_gl_interop.h>

#include <memory>
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
    CopyStream = std::make_unique<Stream>(); // on the context's GPU
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
    if (CopyStream)
      cudaStreamSynchronize(CopyStream->get()); // a copy in flight ends before the texture is unregistered
    if (Resource)
      cudaGraphicsUnregisterResource(Resource); // nothing may leave a destructor
  }

  unsigned int texture() const override { return Texture; }
  int width() const override { return Width; }
  int height() const override { return Height; }

  void write(const float* deviceRgba, const void* ready) override
  {
    NV_CHECK(deviceRgba != nullptr, "GlImageTarget::write: no image");
    cudaPointerAttributes attributes{};
    NV_CUDA(cudaPointerGetAttributes(&attributes, deviceRgba));
    NV_CHECK(attributes.type == cudaMemoryTypeDevice && attributes.device == Device,
      "GlImageTarget::write: the image is not in the memory of the GPU that runs the OpenGL context");
    const size_t row = static_cast<size_t>(Width) * kPixelBytes;
    if (!ready)
    {
      Mapped mapped(Resource);
      NV_CUDA(cudaMemcpy2DToArray(mapped.array, 0, 0, deviceRgba, row, row, static_cast<size_t>(Height),
        cudaMemcpyDeviceToDevice));
      return;
    }
    // A render still on the GPU: the copy waits for its event on this target's stream, the unmap orders OpenGL's
    // later use of the texture after the copy; nothing here waits on the host.
    NV_CUDA(cudaStreamWaitEvent(CopyStream->get(), static_cast<cudaEvent_t>(const_cast<void*>(ready)), 0));
    Mapped mapped(Resource, CopyStream->get());
    NV_CUDA(cudaMemcpy2DToArrayAsync(mapped.array, 0, 0, deviceRgba, row, row, static_cast<size_t>(Height),
      cudaMemcpyDeviceToDevice, CopyStream->get()));
  }

  void read(std::vector<float>& rgba) override
  {
    const size_t row = static_cast<size_t>(Width) * kPixelBytes;
    rgba.resize(static_cast<size_t>(Width) * static_cast<size_t>(Height) * 4);
    NV_CUDA(cudaStreamSynchronize(CopyStream->get())); // a deferred write() first
    Mapped mapped(Resource);
    NV_CUDA(cudaMemcpy2DFromArray(rgba.data(), row, mapped.array, 0, 0, row, static_cast<size_t>(Height),
      cudaMemcpyDeviceToHost));
  }

private:
  /// The texture mapped for CUDA while it lives (OpenGL must not touch it meanwhile); unmapped on every exit.
  struct Mapped
  {
    explicit Mapped(cudaGraphicsResource_t r, cudaStream_t s = 0)
      : resource(r)
      , stream(s)
    {
      NV_CUDA(cudaGraphicsMapResources(1, &resource, stream));
      const cudaError_t e = cudaGraphicsSubResourceGetMappedArray(&array, resource, 0, 0);
      if (e != cudaSuccess)
      {
        cudaGraphicsUnmapResources(1, &resource, stream);
        throwCuda(e, "cudaGraphicsSubResourceGetMappedArray", __FILE__, __LINE__);
      }
    }
    ~Mapped() { cudaGraphicsUnmapResources(1, &resource, stream); }
    Mapped(const Mapped&) = delete;
    Mapped& operator=(const Mapped&) = delete;
    cudaGraphicsResource_t resource;
    cudaStream_t stream;
    cudaArray_t array = nullptr;
  };

  unsigned int Texture;
  int Width;
  int Height;
  int Device = -1;
  cudaGraphicsResource_t Resource = nullptr;
  std::unique_ptr<Stream> CopyStream; ///< write() after a render still on the GPU (RenderResult::deviceReady)
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
