#include "vtkNeuralImageCompositor.h"

#include "Core/GlImageTarget.h"

#include "vtkOpenGLQuadHelper.h"
#include "vtkOpenGLRenderUtilities.h"
#include "vtkOpenGLRenderWindow.h"
#include "vtkOpenGLShaderCache.h"
#include "vtkOpenGLState.h"
#include "vtkRenderer.h"
#include "vtkMultiProcessController.h"
#include "vtkShaderProgram.h"
#include "vtkTextureObject.h"
#include "vtk_glew.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <utility>

namespace
{
double MillisecondsSince(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}
} // namespace

vtkNeuralImageCompositor::vtkNeuralImageCompositor() = default;
vtkNeuralImageCompositor::~vtkNeuralImageCompositor() = default;

//------------------------------------------------------------------------------
bool vtkNeuralImageCompositor::ReadDepth(
  vtkRenderer* ren, int width, int height, std::vector<float>& depth, std::string& message)
{
  auto* window = vtkOpenGLRenderWindow::SafeDownCast(ren->GetRenderWindow());
  if (!window)
  {
    message = "not an OpenGL render window";
    return false;
  }
  int vw = 0, vh = 0, vx = 0, vy = 0;
  ren->GetTiledSizeAndOrigin(&vw, &vh, &vx, &vy);
  if (vw < 1 || vh < 1)
  {
    message = "empty viewport";
    return false;
  }
  vtkOpenGLState* state = window->GetState();
  // Read from the framebuffer being drawn into (opaque geometry is already there).
  GLint drawBinding = 0, samples = 0;
  state->vtkglGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &drawBinding);
  state->vtkglGetIntegerv(GL_SAMPLES, &samples);
  if (samples > 0)
  {
    message = "the framebuffer is multisampled";
    return false;
  }
  while (glGetError() != GL_NO_ERROR)
  {
  }
  state->PushReadFramebufferBinding();
  state->vtkglBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<unsigned int>(drawBinding));
  state->vtkglPixelStorei(GL_PACK_ALIGNMENT, 4);
  this->Scratch.resize(static_cast<size_t>(vw) * static_cast<size_t>(vh));
  glReadPixels(vx, vy, vw, vh, GL_DEPTH_COMPONENT, GL_FLOAT, this->Scratch.data());
  const GLenum error = glGetError();
  state->PopReadFramebufferBinding();
  if (error != GL_NO_ERROR)
  {
    message = "glReadPixels of the depth buffer failed";
    return false;
  }
  depth.resize(static_cast<size_t>(width) * static_cast<size_t>(height));
  if (width == vw && height == vh)
  {
    std::copy(this->Scratch.begin(), this->Scratch.end(), depth.begin());
    return true;
  }
  // A reduced image: the depth at each of its pixel centres.
  for (int y = 0; y < height; ++y)
  {
    const int sy = std::min(vh - 1, static_cast<int>((y + 0.5) * vh / height));
    for (int x = 0; x < width; ++x)
    {
      const int sx = std::min(vw - 1, static_cast<int>((x + 0.5) * vw / width));
      depth[static_cast<size_t>(y) * width + x] = this->Scratch[static_cast<size_t>(sy) * vw + sx];
    }
  }
  return true;
}

//------------------------------------------------------------------------------
void vtkNeuralImageCompositor::SetImage(std::vector<float>&& rgba, int width, int height)
{
  this->Image = std::move(rgba);
  this->Width = width;
  this->Height = height;
  this->Uploaded = false;
  this->OnDevice = false;
}

void vtkNeuralImageCompositor::Clear()
{
  this->Image.clear();
  this->Width = this->Height = 0;
  this->Uploaded = false;
  this->OnDevice = false;
}

//------------------------------------------------------------------------------
vtkTextureObject* vtkNeuralImageCompositor::Texture() const
{
  return this->Slots[this->Current].Texture;
}

std::unique_ptr<nv::GlImageTarget>& vtkNeuralImageCompositor::Target()
{
  return this->Slots[this->Current].Target;
}

bool vtkNeuralImageCompositor::PrepareTexture(vtkWindow* window)
{
  auto* context = vtkOpenGLRenderWindow::SafeDownCast(window);
  if (!context)
  {
    return false;
  }
  ++this->Uses;
  int chosen = -1;
  for (int k = 0; k < kTextureSlots && chosen < 0; ++k)
  {
    vtkTextureObject* texture = this->Slots[k].Texture;
    if (texture && texture->GetHandle() != 0 && texture->GetContext() == context &&
      static_cast<int>(texture->GetWidth()) == this->Width && static_cast<int>(texture->GetHeight()) == this->Height)
    {
      chosen = k;
    }
  }
  if (chosen >= 0)
  {
    this->Current = chosen;
    this->Slots[chosen].LastUse = this->Uses;
    return true;
  }
  chosen = 0;
  for (int k = 1; k < kTextureSlots; ++k)
  {
    if (this->Slots[k].LastUse < this->Slots[chosen].LastUse)
    {
      chosen = k;
    }
  }
  TextureSlot& slot = this->Slots[chosen];
  this->Current = chosen;
  slot.LastUse = this->Uses;
  slot.Target.reset(); // registered with the texture that is replaced
  if (!slot.Texture)
  {
    slot.Texture = vtkSmartPointer<vtkTextureObject>::New();
  }
  vtkTextureObject* texture = slot.Texture;
  texture->SetContext(context);
  texture->SetMinificationFilter(vtkTextureObject::Linear);
  texture->SetMagnificationFilter(vtkTextureObject::Linear);
  texture->SetWrapS(vtkTextureObject::ClampToEdge);
  texture->SetWrapT(vtkTextureObject::ClampToEdge);
  return texture->Allocate2D(
    static_cast<unsigned int>(this->Width), static_cast<unsigned int>(this->Height), 4, VTK_FLOAT);
}

bool vtkNeuralImageCompositor::SetDeviceImage(
  vtkRenderer* ren, const float* deviceRgba, const void* ready, int width, int height, std::string& why)
{
  const auto start = std::chrono::steady_clock::now();
  this->Image.clear();
  this->Width = width;
  this->Height = height;
  this->Uploaded = false;
  this->OnDevice = false;
  if (!this->PrepareTexture(ren->GetRenderWindow()))
  {
    why = "no OpenGL texture for the image";
    return false;
  }
  try
  {
    std::unique_ptr<nv::GlImageTarget>& target = this->Target();
    if (!target || target->texture() != this->Texture()->GetHandle())
    {
      target = nv::GlImageTarget::create(this->Texture()->GetHandle(), width, height);
    }
    target->write(deviceRgba, ready);
  }
  catch (const std::exception& e)
  {
    this->Target().reset();
    why = e.what();
    return false;
  }
  this->Uploaded = true;
  this->OnDevice = true;
  this->UploadMilliseconds = MillisecondsSince(start);
  return true;
}

const std::vector<float>& vtkNeuralImageCompositor::GetImage()
{
  if (this->OnDevice && this->Texture() && this->Texture()->GetContext())
  {
    this->Texture()->GetContext()->MakeCurrent();
    this->ReadBack();
  }
  return this->Image;
}

void vtkNeuralImageCompositor::ReadBack()
{
  if (!this->OnDevice || !this->Target())
  {
    return;
  }
  try
  {
    this->Target()->read(this->Image);
  }
  catch (const std::exception&)
  {
    this->Image.clear(); // the next Draw() has nothing to upload: it draws nothing rather than a stale picture
  }
  this->OnDevice = false;
}

//------------------------------------------------------------------------------
void vtkNeuralImageCompositor::Draw(vtkRenderer* ren)
{
  auto* window = vtkOpenGLRenderWindow::SafeDownCast(ren->GetRenderWindow());
  if (!window || this->Width < 1 || this->Height < 1)
  {
    return;
  }
  const bool lostTexture =
    !this->Texture() || this->Texture()->GetHandle() == 0 || this->Texture()->GetContext() != window;
  if (this->OnDevice && lostTexture)
  {
    this->ReadBack(); // a new context: the picture comes back from the old texture to the host
  }
  if (!this->Uploaded || lostTexture)
  {
    const auto start = std::chrono::steady_clock::now();
    if (this->Image.size() != static_cast<size_t>(this->Width) * static_cast<size_t>(this->Height) * 4 ||
      !this->PrepareTexture(window))
    {
      return;
    }
    // In place: the texture keeps its storage while the image size does not change.
    this->Texture()->Activate();
    vtkOpenGLState* uploadState = window->GetState();
    uploadState->vtkglPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, this->Width, this->Height, GL_RGBA, GL_FLOAT, this->Image.data());
    this->Texture()->Deactivate();
    this->Uploaded = true;
    this->UploadMilliseconds = MillisecondsSince(start);
  }
  const auto drawStart = std::chrono::steady_clock::now();

  vtkOpenGLState* state = window->GetState();
  vtkOpenGLState::ScopedglEnableDisable blend(state, GL_BLEND);
  vtkOpenGLState::ScopedglEnableDisable depthTest(state, GL_DEPTH_TEST);
  vtkOpenGLState::ScopedglBlendFuncSeparate blendFunc(state);
  vtkOpenGLState::ScopedglDepthMask depthMask(state);
  vtkOpenGLState::ScopedglViewport viewport(state);

  int vw = 0, vh = 0, vx = 0, vy = 0;
  ren->GetTiledSizeAndOrigin(&vw, &vh, &vx, &vy);
  state->vtkglViewport(vx, vy, vw, vh);
  state->vtkglEnable(GL_BLEND);
  // Premultiplied colour over the framebuffer.
  state->vtkglBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  state->vtkglDisable(GL_DEPTH_TEST);
  state->vtkglDepthMask(GL_FALSE);

  vtkTextureObject* texture = this->Texture();
  texture->Activate();
  if (!this->Quad)
  {
    std::string fs = vtkOpenGLRenderUtilities::GetFullScreenQuadFragmentShaderTemplate();
    vtkShaderProgram::Substitute(fs, "//VTK::FSQ::Decl", "uniform sampler2D image;\nuniform int clampToAlpha;");
    vtkShaderProgram::Substitute(fs, "//VTK::FSQ::Impl",
      "vec4 c = texture2D(image, texCoord);\n"
      "  if (clampToAlpha != 0) c.rgb = min(c.rgb, vec3(c.a));\n"
      "  gl_FragData[0] = c;");
    this->Quad.reset(new vtkOpenGLQuadHelper(
      window, vtkOpenGLRenderUtilities::GetFullScreenQuadVertexShader().c_str(), fs.c_str(), ""));
  }
  else
  {
    window->GetShaderCache()->ReadyShaderProgram(this->Quad->Program);
  }
  if (this->Quad->Program)
  {
    this->Quad->Program->SetUniformi("image", texture->GetTextureUnit());
    // Under MPI the ranks' pictures are blended by ParaView's compositor (IceT) in 8-bit premultiplied colour
    // without saturation: a colour above its alpha (the light of path tracing or specular highlights in front of a
    // translucent sample) would wrap around where a brighter piece lies behind. It is clamped to its alpha there.
    vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
    const bool distributed = controller && controller->GetNumberOfProcesses() > 1;
    this->Quad->Program->SetUniformi("clampToAlpha", distributed ? 1 : 0);
    this->Quad->Render();
  }
  texture->Deactivate();
  this->DrawMilliseconds = MillisecondsSince(drawStart);
}

//------------------------------------------------------------------------------
void vtkNeuralImageCompositor::DrawProgress(vtkRenderer* ren, double fraction)
{
  auto* window = vtkOpenGLRenderWindow::SafeDownCast(ren->GetRenderWindow());
  if (!window)
  {
    return;
  }
  constexpr int kProgressBarHeight = 4;
  int vw = 0, vh = 0, vx = 0, vy = 0;
  ren->GetTiledSizeAndOrigin(&vw, &vh, &vx, &vy);
  if (vw < 1 || vh < 1)
  {
    return;
  }
  const int height = std::min(vh, kProgressBarHeight);
  const int filled = static_cast<int>(std::lround(std::max(0.0, std::min(1.0, fraction)) * vw));
  vtkOpenGLState* state = window->GetState();
  vtkOpenGLState::ScopedglEnableDisable scissorTest(state, GL_SCISSOR_TEST);
  vtkOpenGLState::ScopedglScissor scissor(state);
  vtkOpenGLState::ScopedglClearColor clearColor(state);
  vtkOpenGLState::ScopedglColorMask colorMask(state);
  state->vtkglEnable(GL_SCISSOR_TEST);
  state->vtkglColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  // The track, then the finished part (opaque: ParaView's views keep the framebuffer's alpha at 1).
  state->vtkglScissor(vx, vy, vw, height);
  state->vtkglClearColor(0.12f, 0.12f, 0.14f, 1.0f);
  state->vtkglClear(GL_COLOR_BUFFER_BIT);
  if (filled > 0)
  {
    state->vtkglScissor(vx, vy, filled, height);
    state->vtkglClearColor(0.35f, 0.7f, 1.0f, 1.0f);
    state->vtkglClear(GL_COLOR_BUFFER_BIT);
  }
}

//------------------------------------------------------------------------------
void vtkNeuralImageCompositor::ReleaseGraphicsResources(vtkWindow* window)
{
  this->ReadBack(); // the host keeps a GPU picture for the next context
  for (TextureSlot& slot : this->Slots)
  {
    slot.Target.reset(); // unregistered while its texture still exists
    if (slot.Texture)
    {
      slot.Texture->ReleaseGraphicsResources(window);
    }
  }
  this->Quad.reset();
  this->Uploaded = false;
}
