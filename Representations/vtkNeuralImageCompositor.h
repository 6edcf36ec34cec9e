// Private to NeuralVolume::Representations: the OpenGL side of vtkNeuralVolumeMapper. Reads the window depth of
// the opaque geometry already drawn in the renderer's viewport, and draws the engine's premultiplied RGBA image as
// a textured quad over the viewport (blend ONE, ONE_MINUS_SRC_ALPHA) so that it composites over what is in the
// framebuffer, and a progress bar for long refinements. Works on any OpenGL 3.2 context (Mesa/Xvfb included); every GL state it changes is restored.
#ifndef vtkNeuralImageCompositor_h
#define vtkNeuralImageCompositor_h

#include "vtkSmartPointer.h"

#include <memory>
#include <string>
#include <vector>

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
  bool HasImage() const { return this->Width > 0; }
  const std::vector<float>& GetImage() const { return this->Image; }
  void Clear();

  /// Composite the uploaded image over the renderer's viewport (scaled to it, linear filtering).
  void Draw(vtkRenderer* ren);

  /// A thin progress bar (kProgressBarHeight pixels) along the bottom of the renderer's viewport, `fraction` of it
  /// filled: drawn over the image while a long refinement runs.
  void DrawProgress(vtkRenderer* ren, double fraction);

  void ReleaseGraphicsResources(vtkWindow* window);

private:
  vtkSmartPointer<vtkTextureObject> Texture;
  std::unique_ptr<vtkOpenGLQuadHelper> Quad;
  std::vector<float> Image;
  int Width = 0;
  int Height = 0;
  bool Uploaded = false;
  std::vector<float> Scratch;
};

#endif
