// NeuralVolume engine: CUDA-OpenGL interop -- a rendered image (RenderResult::deviceRgba, a render to
// Memory::Device) written straight into an OpenGL texture on the GPU, with no copy to the host and no upload.
// VTK-free; the caller owns the texture and its OpenGL context, which must be current in the calling thread for
// every call (create, write, read and the destructor).
//
//   auto target = nv::GlImageTarget::create(textureName, width, height);   // throws nv::Error when it cannot
//   session->render(request, result, nv::Memory::Device);
//   target->write(result.deviceRgba);                                      // the texture now holds the picture
#pragma once

#include <memory>
#include <vector>

namespace nv
{

class GlImageTarget
{
public:
  /// Registers `texture` (a GL_TEXTURE_2D of internal format GL_RGBA32F, width x height) with CUDA. Throws nv::Error
  /// saying why when it cannot: a build without CUDA, no usable GPU, an OpenGL context that does not run on an
  /// NVIDIA GPU that CUDA sees (Mesa, a remote X server), a texture of another format.
  static std::unique_ptr<GlImageTarget> create(unsigned int texture, int width, int height);

  virtual ~GlImageTarget() = default;
  virtual unsigned int texture() const = 0;
  virtual int width() const = 0;
  virtual int height() const = 0;

  /// Copies width * height premultiplied RGBA floats, row 0 at the bottom, from device memory of the GPU the
  /// OpenGL context runs on into the texture (a device-to-device copy). `ready` (RenderResult::deviceReady, may be
  /// null): the copy waits on the GPU for that event and write() returns without waiting for the GPU; OpenGL's
  /// later use of the texture is ordered after the copy either way.
  virtual void write(const float* deviceRgba, const void* ready = nullptr) = 0;
  /// The texture's pixels, as write() received them (tests, and callers that need the picture on the host).
  virtual void read(std::vector<float>& rgba) = 0;
};

} // namespace nv
