#include "vtkNeuralVolumeMapper.h"

#include "Core/ValueRange.h"

#include "vtkNeuralImageCompositor.h"
#include "vtkNeuralNetworkArray.h"
#include "vtkNeuralProgressiveRenderer.h"
#include "vtkNeuralRenderRequest.h"

#include "Core/NetworkSession.h"
#include "Core/Render.h"
#include "Core/RenderSetup.h"
#include "Core/ResourceEstimate.h"

#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkObjectFactory.h"
#include "vtkRenderWindow.h"
#include "vtkRenderer.h"
#include "vtkUnsignedCharArray.h"
#include "vtkVolume.h"
#include "vtkVolumeProperty.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

vtkStandardNewMacro(vtkNeuralVolumeMapper);

namespace
{
/// Entries of the transfer-function table handed to the engine.
constexpr int kTransferEntries = 1024;
/// A still render polls a progressive decode this often (a render of an unchanged request while the coarse grid is
/// still in use returns the previous image without marching) and gives up after kMaxDecodeWait.
constexpr std::chrono::milliseconds kDecodePoll(20);
constexpr std::chrono::seconds kMaxDecodeWait(600);
/// Progressive mode: a new request waits at most this multiple of FrameBudget for its first image (then the previous
/// picture is drawn and the refresh driver shows the new one when it is ready).
constexpr double kFirstImageWait = 1.5;
/// Progressive mode, a network that trains: the share of the time its live picture may take to redraw new versions.
constexpr double kLiveRenderShare = 0.5;
/// Progressive mode: the progress bar appears once a refinement has run this long.
constexpr double kProgressDelaySeconds = 0.3;

uint64_t Mix(uint64_t h, uint64_t v)
{
  h ^= v + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
  return h;
}
} // namespace

struct vtkNeuralVolumeMapper::vtkInternals
{
  // The network: the array it came from and its session.
  vtkUnsignedCharArray* NetworkArray = nullptr;
  vtkMTimeType NetworkTime = 0;
  std::shared_ptr<nv::NetworkSession> Session;
  bool FromBytes = false;

  // Transfer function sampled from the volume property (resampled when the property changes).
  vtkVolumeProperty* TfProperty = nullptr;
  vtkMTimeType TfTime = 0;
  nv::TransferFunction Tf;

  // The last image and what it shows.
  vtkNeuralImageCompositor Compositor;
  nv::RenderResult Result;
  nv::RenderStats Stats;
  uint64_t Key = 0;
  bool HaveImage = false;
  int Size[2] = { 0, 0 };
  int EngineRenders = 0;
  bool WorkPending = false;
  std::vector<float> Depth;

  // Progressive mode (ProgressiveRefinement on, CPU engine): the background renderer and what the image shows.
  std::unique_ptr<vtkNeuralProgressiveRenderer> Worker;
  bool WorkerRefused = false; ///< the system gave no thread for it: renders block
  double ImageScale = 1.0;
  int ImageLevel = 0;
  int ImageLevels = 1;
  bool ImageFinal = true;
  double Progress = 1.0;

  // The decode grid's resolution: the one asked for (DecodeResolution, or the trained dims) clamped to what the machine
  // holds, decided once per request and network (the clamp does not follow the free memory render by render).
  int DecodeAsked[3] = { -1, -1, -1 };
  const void* DecodeSession = nullptr;
  int DecodeUsed[3] = { 0, 0, 0 };

  std::string LastError;
  std::string Reported;
  std::set<int> WarnedBlendModes;
  bool WarnedDepth = false;
};

//------------------------------------------------------------------------------
vtkNeuralVolumeMapper::vtkNeuralVolumeMapper()
  : StreamingSamples(nv::kDefaultStreamingSamples)
  , Internals(new vtkInternals)
{
}

vtkNeuralVolumeMapper::~vtkNeuralVolumeMapper() = default;

//------------------------------------------------------------------------------
int vtkNeuralVolumeMapper::GetLastRenderPath() const
{
  return static_cast<int>(this->Internals->Stats.path);
}
double vtkNeuralVolumeMapper::GetLastSamplesEvaluated() const
{
  return static_cast<double>(this->Internals->Stats.samplesEvaluated);
}
double vtkNeuralVolumeMapper::GetLastSamplesPlain() const
{
  return static_cast<double>(this->Internals->Stats.samplesPlain);
}
double vtkNeuralVolumeMapper::GetLastWavefronts() const
{
  return static_cast<double>(this->Internals->Stats.wavefronts);
}
int vtkNeuralVolumeMapper::GetLastAccumulatedFrames() const
{
  return this->Internals->Stats.accumulatedFrames;
}
void vtkNeuralVolumeMapper::GetLastImageSize(int size[2]) const
{
  size[0] = this->Internals->Size[0];
  size[1] = this->Internals->Size[1];
}
bool vtkNeuralVolumeMapper::GetLastDecodePending() const
{
  return this->Internals->Stats.decodePending;
}
double vtkNeuralVolumeMapper::GetLastRenderMilliseconds() const
{
  return this->Internals->Stats.renderMilliseconds + this->Internals->Stats.decodeMilliseconds;
}
int vtkNeuralVolumeMapper::GetEngineRenderCount() const
{
  const vtkInternals& in = *this->Internals;
  return in.EngineRenders + (in.Worker ? in.Worker->EngineRenders() : 0);
}
double vtkNeuralVolumeMapper::GetLastImageScale() const
{
  return this->Internals->ImageScale;
}
int vtkNeuralVolumeMapper::GetLastRefinementLevel() const
{
  return this->Internals->ImageLevel;
}
int vtkNeuralVolumeMapper::GetLastRefinementLevels() const
{
  return this->Internals->ImageLevels;
}
bool vtkNeuralVolumeMapper::GetLastImageFinal() const
{
  return this->Internals->ImageFinal;
}
double vtkNeuralVolumeMapper::GetRefinementProgress() const
{
  return this->Internals->Progress;
}
int vtkNeuralVolumeMapper::GetAbandonedRefinements() const
{
  return this->Internals->Worker ? this->Internals->Worker->AbandonedJobs() : 0;
}
int vtkNeuralVolumeMapper::GetCancelledEngineRenders() const
{
  return this->Internals->Worker ? this->Internals->Worker->CancelledRenders() : 0;
}
double vtkNeuralVolumeMapper::GetLastAbandonMilliseconds() const
{
  return this->Internals->Worker ? this->Internals->Worker->LastAbandonMilliseconds() : 0.0;
}
void vtkNeuralVolumeMapper::GetLastImage(vtkFloatArray* rgba) const
{
  if (!rgba)
  {
    return;
  }
  const std::vector<float>& image = this->Internals->Compositor.GetImage();
  rgba->SetNumberOfComponents(4);
  rgba->SetNumberOfTuples(static_cast<vtkIdType>(image.size() / 4));
  std::copy(image.begin(), image.end(), rgba->GetPointer(0));
}
bool vtkNeuralVolumeMapper::GetWorkPending() const
{
  return this->Internals->WorkPending;
}
bool vtkNeuralVolumeMapper::HasNetwork() const
{
  return this->Internals->Session != nullptr;
}
bool vtkNeuralVolumeMapper::GetSessionFromBytes() const
{
  return this->Internals->FromBytes;
}
const char* vtkNeuralVolumeMapper::GetLastError() const
{
  return this->Internals->LastError.c_str();
}

int vtkNeuralVolumeMapper::GetScalarMode()
{
  return VTK_SCALAR_MODE_USE_FIELD_DATA;
}
int vtkNeuralVolumeMapper::GetArrayAccessMode()
{
  return VTK_GET_ARRAY_BY_NAME;
}
char* vtkNeuralVolumeMapper::GetArrayName()
{
  static std::string name = vtkNeuralNetworkArray::GetArrayName();
  return &name[0];
}

void vtkNeuralVolumeMapper::ReleaseGraphicsResources(vtkWindow* window)
{
  this->Internals->Compositor.ReleaseGraphicsResources(window);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::Render(vtkRenderer* ren, vtkVolume* vol)
{
  vtkInternals& in = *this->Internals;
  // Hardware selection passes draw ids, not colours: the volume takes no part in them.
  if (!ren || !vol || !ren->GetRenderWindow() || ren->GetSelector())
  {
    return;
  }
  if (this->GetInputAlgorithm())
  {
    this->GetInputAlgorithm()->Update();
  }

  // Draw nothing on failure: forget the last image and say why once.
  auto fail = [&](const std::string& message, bool report) {
    in.LastError = message;
    in.HaveImage = false;
    in.WorkPending = false;
    in.Compositor.Clear();
    if (report && message != in.Reported)
    {
      vtkErrorMacro("Neural Volume: " << message);
      in.Reported = message;
    }
  };

  vtkImageData* image = vtkImageData::SafeDownCast(this->GetInput());
  vtkUnsignedCharArray* network = image ? vtkNeuralNetworkArray::Find(image->GetFieldData()) : nullptr;
  if (!network)
  {
    // The representation reports a missing network to the user (once per input).
    in.Session.reset();
    in.NetworkArray = nullptr;
    fail(std::string("the input has no '") + vtkNeuralNetworkArray::GetArrayName() +
        "' field data array",
      false);
    return;
  }
  if (network != in.NetworkArray || network->GetMTime() != in.NetworkTime || !in.Session)
  {
    in.NetworkArray = network;
    in.NetworkTime = network->GetMTime();
    in.Session.reset();
    in.HaveImage = false;
    try
    {
      in.Session = vtkNeuralNetworkArray::Session(image->GetFieldData(), &in.FromBytes);
    }
    catch (const std::exception& e)
    {
      fail(std::string("cannot use the input's network: ") + e.what(), true);
      return;
    }
    catch (...)
    {
      fail("cannot use the input's network", true);
      return;
    }
  }
  nv::NetworkSession& session = *in.Session;

  try
  {
    vtkRenderWindow* window = ren->GetRenderWindow();
    const bool interactive = window->GetDesiredUpdateRate() > 1.0;
    int vw = 0, vh = 0, vx = 0, vy = 0;
    ren->GetTiledSizeAndOrigin(&vw, &vh, &vx, &vy);
    if (vw < 1 || vh < 1)
    {
      return;
    }
    const double scale = interactive ? this->InteractiveImageScale : 1.0;

    nv::RenderRequest q;
    q.width = std::max(1, static_cast<int>(std::lround(vw * scale)));
    q.height = std::max(1, static_cast<int>(std::lround(vh * scale)));
    vtkNeuralRenderRequest::ViewProjection(ren, q.viewProjection);
    std::string message;
    if (!vtkNeuralRenderRequest::WorldToUnit(vol, image, session.model().source, q.worldToUnit, message))
    {
      fail(message, true);
      return;
    }

    // ParaView 5.11's colour maps (a vtkLookupTable under the discretized colour function) abort on a value range
    // whose width overflows a double, as a Surface coloured by such a field does: refuse before evaluating them.
    const nv::SourceInfo& src = session.model().source;
    if (nv::ValueRange(src.valueMin, src.valueMax).halved())
    {
      std::ostringstream os;
      os << "the values span " << src.valueMin << " to " << src.valueMax << ", a range wider than the largest "
         << "double; ParaView's colour maps cannot map it (VTK aborts). Scale the field first (e.g. with the "
            "Calculator) to draw it.";
      fail(os.str(), true);
      return;
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

    q.path = static_cast<nv::RenderPath>(this->RenderPath);
    int shading = this->ShadingMode;
    if (shading == RAY_MARCHING && property->GetShade(0))
    {
      shading = RAY_MARCHING_GRADIENT;
    }
    q.shading = static_cast<nv::ShadingMode>(shading);
    switch (this->BlendMode)
    {
      case COMPOSITE_BLEND:
        q.blend = nv::BlendMode::Composite;
        break;
      case MAXIMUM_INTENSITY_BLEND:
        q.blend = nv::BlendMode::Maximum;
        break;
      case MINIMUM_INTENSITY_BLEND:
        q.blend = nv::BlendMode::Minimum;
        break;
      case AVERAGE_INTENSITY_BLEND:
        q.blend = nv::BlendMode::Average;
        break;
      case ADDITIVE_BLEND:
        q.blend = nv::BlendMode::Additive;
        break;
      default:
        q.blend = nv::BlendMode::Composite;
        if (in.WarnedBlendModes.insert(this->BlendMode).second)
        {
          vtkWarningMacro("Neural Volume: the "
            << (this->BlendMode == ISOSURFACE_BLEND ? "Isosurface"
                 : this->BlendMode == SLICE_BLEND   ? "Slice"
                                                    : "requested")
            << " blend mode is not available for a network; rendering with Composite.");
        }
        break;
    }
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
    q.streamingSamples = this->StreamingSamples;
    q.emptySpaceSkipping = this->EmptySpaceSkipping;
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
    std::copy(in.DecodeUsed, in.DecodeUsed + 3, q.decodeResolution);
    // A still render that returns the final picture (scripts, pvbatch) decodes the full grid at once on every
    // thread of the session rather than showing a coarse grid and polling a one-thread background decode.
    q.waitForDecode = !this->ProgressiveRefinement && !interactive;
    q.seed = 1;

    // Opaque geometry drawn before the volumes hides what lies behind it.
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

    // Everything that changes the picture; the engine's own key plus the network.
    const uint64_t sceneKey = Mix(nv::renderKey(q), reinterpret_cast<uintptr_t>(&session));
    const uint64_t key = Mix(sceneKey, session.version());
    const bool pathTracing = shading >= PATH_TRACING;
    auto accumulated = [&]() { return static_cast<int64_t>(in.Stats.accumulatedFrames) * q.samplesPerPixel; };
    auto renderOnce = [&]() {
      session.render(q, in.Result);
      if (!in.Result.stats.reused)
      {
        ++in.EngineRenders; // the engine rendered (not only returned its previous image)
      }
      in.Stats = in.Result.stats;
      const size_t expected = static_cast<size_t>(q.width) * static_cast<size_t>(q.height) * 4;
      if (in.Result.rgba.size() != expected)
      {
        throw std::runtime_error("the engine returned an image of the wrong size");
      }
      in.Compositor.SetImage(std::move(in.Result.rgba), q.width, q.height);
      in.Size[0] = q.width;
      in.Size[1] = q.height;
      in.Key = key;
      in.HaveImage = true;
    };

    if (this->ProgressiveRefinement && session.device() == nv::Device::Cpu && !in.WorkerRefused)
    {
      // In the background: this render only starts or continues the work and draws the newest image.
      const int frames = pathTracing && !interactive
        ? std::max(1, (this->TargetSamples + q.samplesPerPixel - 1) / q.samplesPerPixel)
        : 1;
      std::string error;
      const bool drawn = this->RenderInBackground(q, Mix(key, static_cast<uint64_t>(frames)),
        Mix(sceneKey, static_cast<uint64_t>(frames)), frames, scale, error);
      if (!drawn && !in.WorkerRefused)
      {
        fail(error, true);
        return;
      }
      if (drawn)
      {
        in.LastError.clear();
        in.Reported.clear();
        this->DrawImage(ren);
        return;
      }
    }
    if (in.Worker)
    {
      in.Worker->Cancel(); // back to blocking renders (a script turned ProgressiveRefinement off)
    }
    in.ImageScale = scale;
    in.ImageLevel = 0;
    in.ImageLevels = 1;
    in.ImageFinal = true;
    in.Progress = 1.0;

    const bool same = in.HaveImage && key == in.Key;
    bool render = !same;
    if (same && in.Stats.decodePending)
    {
      render = true; // hands the refined grid out when it is ready (else the engine returns the same image)
    }
    if (same && pathTracing && !interactive && accumulated() < this->TargetSamples)
    {
      render = true; // one more frame into the average
    }
    if (render)
    {
      renderOnce();
      if (!this->ProgressiveRefinement && !interactive)
      {
        // A still render returns the final picture: wait for the refined grid, accumulate to the target.
        const auto waitStart = std::chrono::steady_clock::now();
        for (int guard = 0; guard < (1 << 24); ++guard)
        {
          if (in.Stats.decodePending)
          {
            // The engine keeps workPending() until a render hands the refined grid out: render again until the
            // picture no longer uses a coarse grid. Nothing running, or too long: keep the coarse picture.
            if (!session.workPending())
            {
              break;
            }
            if (std::chrono::steady_clock::now() - waitStart > kMaxDecodeWait)
            {
              vtkWarningMacro("Neural Volume: the full decode grid is not ready after "
                << kMaxDecodeWait.count() << " s; showing the coarse grid.");
              break;
            }
            std::this_thread::sleep_for(kDecodePoll);
            renderOnce();
          }
          else if (pathTracing && accumulated() < this->TargetSamples)
          {
            renderOnce();
          }
          else
          {
            break;
          }
        }
      }
    }
    in.WorkPending = in.Stats.decodePending || session.workPending() ||
      (pathTracing && !interactive && accumulated() < this->TargetSamples);
    in.LastError.clear();
    in.Reported.clear();
  }
  catch (const std::bad_alloc&)
  {
    fail("rendering failed: out of memory (lower DecodeResolution or the view's size)", true);
    return;
  }
  catch (const std::exception& e)
  {
    fail(std::string("rendering failed: ") + e.what(), true);
    return;
  }
  catch (...)
  {
    // Nothing may leave a render: ParaView would abort and lose the session.
    fail("rendering failed (unexpected error)", true);
    return;
  }

  this->DrawImage(ren);
}

//------------------------------------------------------------------------------
bool vtkNeuralVolumeMapper::RenderInBackground(const nv::RenderRequest& q, uint64_t key, uint64_t sceneKey,
  int frames, double viewScale, std::string& error)
{
  vtkInternals& in = *this->Internals;
  try
  {
    if (!in.Worker)
      in.Worker.reset(new vtkNeuralProgressiveRenderer);
  }
  catch (const std::system_error& e)
  {
    in.WorkerRefused = true; // this render and the next ones block instead
    vtkWarningMacro("Neural Volume: the system refused a thread for progressive rendering ("
      << e.what() << "); frames render in the GUI thread.");
    return false;
  }
  vtkNeuralProgressiveRenderer& worker = *in.Worker;
  // A network that trains publishes ~10 versions a second: a refinement of the same scene goes on (its later levels
  // render the network of their moment) instead of restarting at every version and never finishing.
  // And once it is drawn, the next version of the same scene waits until drawing took at most kLiveRenderShare of
  // the time: the training beside it keeps the rest of the cores.
  const bool sameScene = worker.CurrentSceneKey() == sceneKey;
  const bool sameSceneInFlight = sameScene && worker.Busy();
  const bool resting = sameScene && !worker.Busy() && !worker.RestedAfterLastJob(kLiveRenderShare);
  if (worker.CurrentKey() != key && !sameSceneInFlight && !resting)
  {
    // A new picture: abandon the refinement in flight, start this one and wait a frame's budget for its first image.
    vtkNeuralProgressiveRenderer::Job job;
    job.Session = in.Session;
    job.Request = q;
    job.Request.depth = nullptr;
    if (q.depth)
    {
      job.Depth.assign(q.depth, q.depth + static_cast<size_t>(q.width) * static_cast<size_t>(q.height));
    }
    job.Key = key;
    job.SceneKey = sceneKey;
    job.Frames = frames;
    job.BudgetMilliseconds = this->FrameBudget;
    worker.Start(std::move(job));
    worker.WaitForImage(kFirstImageWait * this->FrameBudget);
  }
  const bool busy = worker.Busy();
  error = worker.TakeError();
  if (!error.empty())
  {
    return false;
  }
  vtkNeuralProgressiveRenderer::Image image;
  if (worker.TakeImage(image))
  {
    in.Stats = image.Stats;
    in.Size[0] = image.Width;
    in.Size[1] = image.Height;
    in.ImageScale = viewScale * image.Scale;
    in.ImageLevel = image.Level;
    in.ImageLevels = image.Levels;
    in.ImageFinal = image.Final;
    in.Compositor.SetImage(std::move(image.Rgba), image.Width, image.Height);
    in.HaveImage = true;
    in.Key = 0; // a blocking render after this one renders its own picture
  }
  in.Progress = worker.Progress();
  in.WorkPending = busy || resting || worker.WaitForImage(0.0);
  return true;
}

void vtkNeuralVolumeMapper::DrawImage(vtkRenderer* ren)
{
  vtkInternals& in = *this->Internals;
  try
  {
    in.Compositor.Draw(ren);
    if (this->ProgressiveRefinement && in.Worker && in.Worker->Busy() &&
      in.Worker->BusySeconds() > kProgressDelaySeconds)
    {
      in.Compositor.DrawProgress(ren, in.Worker->Progress());
    }
  }
  catch (...)
  {
    in.LastError = "drawing the rendered image failed";
    vtkErrorMacro("Neural Volume: " << in.LastError);
  }
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "RenderPath: " << this->RenderPath << "\n"
     << indent << "ShadingMode: " << this->ShadingMode << "\n"
     << indent << "SampleDistance: " << this->SampleDistance << "\n"
     << indent << "StreamingSamples: " << this->StreamingSamples << "\n"
     << indent << "SamplesPerPixel: " << this->SamplesPerPixel << "\n"
     << indent << "MaxBounces: " << this->MaxBounces << "\n"
     << indent << "TargetSamples: " << this->TargetSamples << "\n"
     << indent << "FollowViewLight: " << this->FollowViewLight << "\n"
     << indent << "LightDirection: " << this->LightDirection[0] << " " << this->LightDirection[1] << " "
     << this->LightDirection[2] << "\n"
     << indent << "EmptySpaceSkipping: " << this->EmptySpaceSkipping << "\n"
     << indent << "DecodeResolution: " << this->DecodeResolution[0] << " " << this->DecodeResolution[1] << " "
     << this->DecodeResolution[2] << "\n"
     << indent << "InteractiveImageScale: " << this->InteractiveImageScale << "\n"
     << indent << "ProgressiveRefinement: " << this->ProgressiveRefinement << "\n"
     << indent << "EngineRenderCount: " << this->GetEngineRenderCount() << "\n"
     << indent << "FrameBudget: " << this->FrameBudget << "\n"
     << indent << "WorkPending: " << this->GetWorkPending() << "\n"
     << indent << "LastImageSize: " << this->Internals->Size[0] << " " << this->Internals->Size[1] << "\n"
     << indent << "LastImageScale: " << this->GetLastImageScale() << "\n"
     << indent << "LastRefinementLevel: " << this->GetLastRefinementLevel() << "\n"
     << indent << "LastRefinementLevels: " << this->GetLastRefinementLevels() << "\n"
     << indent << "LastImageFinal: " << this->GetLastImageFinal() << "\n"
     << indent << "RefinementProgress: " << this->GetRefinementProgress() << "\n"
     << indent << "AbandonedRefinements: " << this->GetAbandonedRefinements() << "\n"
     << indent << "CancelledEngineRenders: " << this->GetCancelledEngineRenders() << "\n"
     << indent << "LastAbandonMilliseconds: " << this->GetLastAbandonMilliseconds() << "\n";
}
