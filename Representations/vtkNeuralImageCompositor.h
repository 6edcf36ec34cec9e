// Private to NeuralVolume::Representations: the OpenGL side of vtkNeuralVolumeMapper. Reads the window depth of
// the opaque geometry already drawn in the renderer's viewport, and draws the engine's premultiplied RGBA image as
// a textured quad over the viewport (blend ONE, ONE_MINUS_SRC_ALPHA) so that it composites over what is in the
// framebuffer, and a progress bar for long refinements. Works on any OpenGL 3.2 context (Mesa/Xvfb included); every
// GL state it changes is restored. Where the context is NVIDIA's and the engine renders on the GPU, the image goes
// from the engine's device memory into the texture through CUDA-OpenGL interop (SetDeviceImage).
#ifndef vtkNeuralImageCompositor_h
#define vtkNeuralImageCompositor_h

#include "vtkSmartPointer.h"

#include <memory>
#include <string>
#include <cstdint>
#include <vector>

namespace nv
{
class GlImageTarget;
}
class vtkOpenGLQuadHelper;
class vtkRenderer;
class vtkTextureObject;
class vtkWindow;

class vtkNeuralImageCompositor
{
public:
  vtkNeuralImageCompositor();
  ~vtkNeuralImageCompositor();
  vtkNeuralImageCompositor(const vtkNeuralImageCompositor&) = delete;
  vtkNeuralImageCompositor& operator=(const vtkNeuralImageCompositor&) = delete;

  /// Window depths in [0,1] of the renderer's viewport resampled (nearest) to width x height, row 0 at the bottom.
  /// False (and `message`) when the framebuffer's depth cannot be read.
  bool ReadDepth(vtkRenderer* ren, int width, int height, std::vector<float>& depth, std::string& message);

  /// Replace the image drawn by Draw(): width * height premultiplied RGBA floats, row 0 at the bottom (kept on the
  /// host too, so that a new OpenGL context gets it again without a new engine render).
  void SetImage(std::vector<float>&& rgba, int width, int height);
  /// Write an image that lies in GPU memory (an engine render to nv::Memory::Device) straight into the texture through
  /// CUDA-OpenGL interop: no host copy, no upload. False, with the reason, when interop is not possible here (the
  /// caller renders to the host instead); the texture is (re)registered when its size or context changes. `ready`
  /// (nv::RenderResult::deviceReady, may be null): the image is complete after that CUDA event; the copy waits for
  /// it on the GPU, not here.
  bool SetDeviceImage(
    vtkRenderer* ren, const float* deviceRgba, const void* ready, int width, int height, std::string& why);
  bool HasImage() const { return this->Width > 0; }
  /// The image on the host (read back from the texture when it came from SetDeviceImage).
  const std::vector<float>& GetImage();
  void Clear();

  /// Wall time of the last image's way into the texture: the upload of a host image (glTexSubImage2D), or the
  /// device-to-device copy of a GPU image; and of the last Draw() (the blended quad).
  double GetUploadMilliseconds() const { return this->UploadMilliseconds; }
  double GetDrawMilliseconds() const { return this->DrawMilliseconds; }

  /// Composite the uploaded image over the renderer's viewport (scaled to it, linear filtering).
  void Draw(vtkRenderer* ren);

  /// A thin progress bar (kProgressBarHeight pixels) along the bottom of the renderer's viewport, `fraction` of it
  /// filled: drawn over the image while a long refinement runs.
  void DrawProgress(vtkRenderer* ren, double fraction);

  void ReleaseGraphicsResources(vtkWindow* window);

private:
  /// The texture (RGBA32F) of the current image's size in `window`'s context: the slot that has it, else the least
  /// recently used slot reallocated at that size.
  bool PrepareTexture(vtkWindow* window);
  /// A GPU image copied from the texture to Image (the texture's context current).
  void ReadBack();

  /// A texture and its CUDA registration. Four slots: a turning view alternates between an interactive image size
  /// (InteractiveImageScale, or one of its two smaller levels: AdaptiveInteractiveScale) and the still one, and
  /// registering a texture with CUDA costs ~25 ms on the H100 -- each size keeps its own.
  struct TextureSlot
  {
    vtkSmartPointer<vtkTextureObject> Texture;
    std::unique_ptr<nv::GlImageTarget> Target; ///< the texture registered with CUDA (SetDeviceImage)
    uint64_t LastUse = 0;
  };
  static constexpr int kTextureSlots = 4;
  TextureSlot Slots[kTextureSlots];
  int Current = 0;    ///< the slot of the current image
  uint64_t Uses = 0;  ///< PrepareTexture calls (the slots' clock)
  vtkTextureObject* Texture() const;
  std::unique_ptr<nv::GlImageTarget>& Target();

  std::unique_ptr<vtkOpenGLQuadHelper> Quad;
  std::vector<float> Image;
  int Width = 0;
  int Height = 0;
  bool Uploaded = false;
  bool OnDevice = false; ///< the texture holds a GPU image that Image does not have yet
  double UploadMilliseconds = 0.0;
  double DrawMilliseconds = 0.0;
  std::vector<float> Scratch;
};

#endif
