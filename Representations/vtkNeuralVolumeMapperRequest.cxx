// vtkNeuralVolumeMapper: a frame's engine request from VTK's render state, the depth of the opaque geometry, and the
// engine call whose image goes to the compositor (through CUDA-OpenGL interop where possible).
#include "vtkNeuralVolumeMapperInternals.h"

#include "vtkNeuralRenderRequest.h"

#include "Core/RenderSetup.h"
#include "Core/ResourceEstimate.h"
#include "Core/ValueRange.h"

#include "vtkAbstractArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkRenderWindow.h"
#include "vtkRenderer.h"
#include "vtkVolume.h"
#include "vtkVolumeProperty.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

using namespace vtkNeuralVolumeMapperDetail;

//------------------------------------------------------------------------------
std::string vtkNeuralVolumeMapper::BuildRequest(vtkRenderer* ren, vtkVolume* vol, vtkImageData* image,
  bool interactive, double scale, nv::RenderRequest& q)
{
  vtkInternals& in = *this->Internals;
  nv::NetworkSession& session = *in.Session;
  int vw = 0, vh = 0, vx = 0, vy = 0;
  ren->GetTiledSizeAndOrigin(&vw, &vh, &vx, &vy);
  q.width = std::max(1, static_cast<int>(std::lround(vw * scale)));
  q.height = std::max(1, static_cast<int>(std::lround(vh * scale)));
  vtkNeuralRenderRequest::ViewProjection(ren, q.viewProjection);
  std::string message;
  if (!vtkNeuralRenderRequest::WorldToUnit(vol, image, session.model().source, q.worldToUnit, message))
  {
    return message;
  }
  vtkNeuralRenderRequest::PieceClipBox(image, session.model().source, q.clipBox);

  message = this->RequestTransferFunction(vol, q);
  if (!message.empty())
  {
    return message;
  }
  this->RequestShading(ren, vol->GetProperty(), interactive, q);
  this->RequestSurroundings(image, q);
  this->FitDecodeGrid();
  std::copy(in.DecodeUsed, in.DecodeUsed + 3, q.decodeResolution);
  this->WarnUnboundedPicture(session, q);
  // A still render that returns the final picture (scripts, pvbatch) decodes the full grid at once on every
  // thread of the session rather than showing a coarse grid and polling a one-thread background decode.
  q.waitForDecode = !this->Progressive() && !interactive;
  q.liveRefreshMilliseconds = interactive ? kLiveRefreshMilliseconds : 0.0;
  // Interop (a render to device memory): return before the GPU finishes, the texture copy waits on the GPU.
  q.deferDeviceSync = true;
  q.seed = 1;
  return std::string();
}

//------------------------------------------------------------------------------
std::string vtkNeuralVolumeMapper::RequestTransferFunction(vtkVolume* vol, nv::RenderRequest& q)
{
  vtkInternals& in = *this->Internals;
  const nv::SourceInfo& src = in.Session->model().source;
  // ParaView 5.11's colour maps (a vtkLookupTable under the discretized colour function) abort on a value range
  // whose width overflows a double, as a Surface coloured by such a field does: refuse before evaluating them.
  if (nv::ValueRange(src.valueMin, src.valueMax).halved())
  {
    std::ostringstream os;
    os << "the values span " << src.valueMin << " to " << src.valueMax << ", a range wider than the largest "
       << "double; ParaView's colour maps cannot map it (VTK aborts). Scale the field first (e.g. with the "
          "Calculator) to draw it.";
    return os.str();
  }
  vtkVolumeProperty* property = vol->GetProperty();
  if (property != in.TfProperty || property->GetMTime() != in.TfTime)
  {
    vtkNeuralRenderRequest::SampleTransferFunction(property, kTransferEntries, in.Tf);
    in.TfProperty = property;
    in.TfTime = property->GetMTime();
  }
  q.transfer = in.Tf;
  if (!(q.transfer.unitDistance > 0.0) || !std::isfinite(q.transfer.unitDistance))
  {
    // ParaView sets the unit distance from the data when the representation is first shown; shown before the
    // network existed (its filter still preparing), it got 0: the trained field's mean spacing instead, as
    // ParaView would have chosen for it.
    q.transfer.unitDistance = (std::fabs(src.spacing[0]) + std::fabs(src.spacing[1]) + std::fabs(src.spacing[2])) / 3.0;
    if (!(q.transfer.unitDistance > 0.0))
      q.transfer.unitDistance = 1.0;
  }
  return std::string();
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::RequestShading(
  vtkRenderer* ren, vtkVolumeProperty* property, bool interactive, nv::RenderRequest& q)
{
  q.path = static_cast<nv::RenderPath>(this->RenderPath);
  int shading = this->ShadingMode;
  if (shading == RAY_MARCHING && property->GetShade(0))
  {
    shading = RAY_MARCHING_GRADIENT;
  }
  q.shading = static_cast<nv::ShadingMode>(shading);
  q.blend = this->EngineBlendMode();
  for (int k = 0; k < 2; ++k)
  {
    q.averageRange[k] = std::max(-1e30, std::min(1e30, this->AverageIPScalarRange[k]));
  }
  q.sampleDistance = this->SampleDistance;
  if (this->FollowViewLight)
  {
    vtkNeuralRenderRequest::ViewLightDirection(ren, q.lightDirection);
  }
  else
  {
    std::copy(this->LightDirection, this->LightDirection + 3, q.lightDirection);
  }
  q.lightIntensity = 1.0;
  q.ambient = property->GetAmbient(0);
  q.diffuse = property->GetDiffuse(0);
  q.specular = property->GetSpecular(0);
  q.specularPower = property->GetSpecularPower(0);
  q.anisotropy = property->GetScatteringAnisotropy();
  q.maxBounces = this->MaxBounces;
  q.samplesPerPixel = interactive ? 1 : this->SamplesPerPixel;
  q.accumulate = true;
  q.denoise = this->Denoise;
  q.streamingSamples = this->StreamingSamples;
  q.emptySpaceSkipping = this->EmptySpaceSkipping;
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::RequestSurroundings(vtkImageData* image, nv::RenderRequest& q)
{
  // Under MPI a rank draws its own piece; the light of shadows and path tracing crosses the other ranks' pieces
  // through the coarse grid of the whole field that Neural Compress gave every piece (engine: RaySurroundings.h).
  // Every other mode, and a serial run (no grid), draws without it.
  q.surroundings = nullptr;
  if (q.shading != nv::ShadingMode::RayMarchShadows && q.shading != nv::ShadingMode::PathTrace &&
    q.shading != nv::ShadingMode::PathTraceNee)
  {
    return;
  }
  vtkInternals& in = *this->Internals;
  vtkAbstractArray* values = image ? image->GetFieldData()->GetAbstractArray("NeuralSurroundings") : nullptr;
  if (!values)
  {
    return;
  }
  if (values != in.SurroundingsArray || values->GetMTime() != in.SurroundingsTime ||
    in.Session.get() != in.SurroundingsSession)
  {
    in.Surroundings = vtkNeuralRenderRequest::PieceSurroundings(image, in.Session->model().source);
    in.SurroundingsArray = values;
    in.SurroundingsTime = values->GetMTime();
    in.SurroundingsSession = in.Session.get();
  }
  q.surroundings = in.Surroundings;
}

//------------------------------------------------------------------------------
nv::BlendMode vtkNeuralVolumeMapper::EngineBlendMode()
{
  switch (this->BlendMode)
  {
    case COMPOSITE_BLEND:
      return nv::BlendMode::Composite;
    case MAXIMUM_INTENSITY_BLEND:
      return nv::BlendMode::Maximum;
    case MINIMUM_INTENSITY_BLEND:
      return nv::BlendMode::Minimum;
    case AVERAGE_INTENSITY_BLEND:
      return nv::BlendMode::Average;
    case ADDITIVE_BLEND:
      return nv::BlendMode::Additive;
    default:
      if (this->Internals->WarnedBlendModes.insert(this->BlendMode).second)
      {
        vtkWarningMacro("Neural Volume: the "
          << (this->BlendMode == ISOSURFACE_BLEND ? "Isosurface"
               : this->BlendMode == SLICE_BLEND   ? "Slice"
                                                  : "requested")
          << " blend mode is not available for a network; rendering with Composite.");
      }
      return nv::BlendMode::Composite;
  }
}

void vtkNeuralVolumeMapper::WarnUnboundedPicture(nv::NetworkSession& session, const nv::RenderRequest& q)
{
  // The error-bounded mode's corrections are applied where the CPU decodes the grid of the trained field's own
  // samples; every other path draws the network's own values (an unbounded picture): said once per network.
  const std::shared_ptr<const nv::ErrorCorrections> corrections = session.errorCorrections();
  const int64_t* dims = session.model().source.dims;
  const bool applied = q.path == nv::RenderPath::Decode && session.device() == nv::Device::Cpu &&
    q.decodeResolution[0] == dims[0] && q.decodeResolution[1] == dims[1] && q.decodeResolution[2] == dims[2];
  vtkInternals& in = *this->Internals;
  if (!corrections || applied || in.WarnedUnbounded == corrections.get())
    return;
  in.WarnedUnbounded = corrections.get();
  vtkWarningMacro("Neural Volume: the network is stored with an error bound (Max Error "
    << corrections->bound << ", " << corrections->count() << " samples corrected), but this render ("
    << (q.path == nv::RenderPath::Decode ? "Decode" : q.path == nv::RenderPath::InShader ? "In-Shader" : "Sample Streaming")
    << " on the " << nv::deviceName(session.device())
    << ") evaluates the network without the corrections: the picture is not error-bounded. The Decode path on the CPU "
       "at the trained resolution (Decode Resolution 0 0 0), and the Neural Compress decoded output, apply them.");
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::FitDecodeGrid()
{
  // The grid asked for (or the trained dims) clamped to what the machine holds, decided once per request and
  // network (the clamp does not follow the free memory render by render).
  vtkInternals& in = *this->Internals;
  nv::NetworkSession& session = *in.Session;
  if (!std::equal(this->DecodeResolution, this->DecodeResolution + 3, in.DecodeAsked) ||
    in.DecodeSession != &session)
  {
    const std::string why = nv::fitDecodeGrid(session.model().source, session.device(), this->DecodeResolution,
      in.DecodeUsed, nv::resolvedSamplesPerAxis(session.model().config().encoding));
    std::copy(this->DecodeResolution, this->DecodeResolution + 3, in.DecodeAsked);
    in.DecodeSession = &session;
    if (!why.empty())
    {
      vtkWarningMacro("Neural Volume: DecodeResolution " << this->DecodeResolution[0] << " "
                                                         << this->DecodeResolution[1] << " "
                                                         << this->DecodeResolution[2] << ": " << why
                                                         << "the network is decoded at " << in.DecodeUsed[0]
                                                         << " x " << in.DecodeUsed[1] << " x " << in.DecodeUsed[2]
                                                         << " instead.");
    }
  }
}


//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::ReadSceneDepth(vtkRenderer* ren, vtkVolume* vol, nv::RenderRequest& q)
{
  vtkInternals& in = *this->Internals;
  const auto start = std::chrono::steady_clock::now();
  in.Timings[0] = 0.0;
  q.depth = nullptr;
  // Opaque geometry drawn before the volumes hides what lies behind it; with none shown the depth buffer holds its
  // clear value everywhere and is not read (a synchronous read of the whole buffer each frame).
  if (!vtkNeuralRenderRequest::ShowsOpaqueGeometry(ren, vol))
  {
    return;
  }
  std::string message;
  if (in.Compositor.ReadDepth(ren, q.width, q.height, in.Depth, message))
  {
    q.depth = in.Depth.data();
  }
  else if (!in.WarnedDepth)
  {
    vtkWarningMacro("Neural Volume: cannot read the depth buffer ("
      << message << "); opaque geometry does not hide the volume.");
    in.WarnedDepth = true;
  }
  in.Timings[0] = MillisecondsSince(start);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::RenderToCompositor(vtkRenderer* ren, const nv::RenderRequest& q)
{
  vtkInternals& in = *this->Internals;
  nv::NetworkSession& session = *in.Session;
  const auto start = std::chrono::steady_clock::now();
  const bool interop = this->CudaGLInterop && session.device() == nv::Device::Cuda && in.InteropRefused.empty();
  auto recordCall = [&]() {
    in.Timings[1] = MillisecondsSince(start);
    in.Timings[2] = in.Result.stats.hostCopyMilliseconds;
    in.Timings[6] = in.Result.stats.decodeMilliseconds;
    in.Timings[7] = in.Result.stats.renderMilliseconds;
  };
  session.render(q, in.Result, interop ? nv::Memory::Device : nv::Memory::Host);
  recordCall();
  if (interop)
  {
    std::string why;
    if (in.Result.deviceRgba &&
      in.Compositor.SetDeviceImage(ren, in.Result.deviceRgba, in.Result.deviceReady, q.width, q.height, why))
    {
      in.DisplayPath = "CUDA-OpenGL interop";
      in.Timings[3] = in.Compositor.GetUploadMilliseconds();
      return;
    }
    // Not possible in this view (GL is not NVIDIA's, ...): the host from now on; this frame again, to the host.
    in.InteropRefused = why.empty() ? std::string("the engine returned no device image") : why;
    session.render(q, in.Result, nv::Memory::Host);
    recordCall();
  }
  const size_t expected = static_cast<size_t>(q.width) * static_cast<size_t>(q.height) * 4;
  if (in.Result.rgba.size() != expected)
  {
    throw std::runtime_error("the engine returned an image of the wrong size");
  }
  in.Compositor.SetImage(std::move(in.Result.rgba), q.width, q.height);
  in.DisplayPath = in.InteropRefused.empty() || !this->CudaGLInterop || session.device() != nv::Device::Cuda
    ? std::string("host copy")
    : "host copy (interop: " + in.InteropRefused + ")";
  in.Timings[3] = -1.0; // the upload happens in Draw()
}

