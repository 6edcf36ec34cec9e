#include "vtkNeuralVolumeMapper.h"
#include "vtkNeuralVolumeMapperInternals.h"

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
#include <limits>
#include <chrono>
#include <cmath>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

vtkStandardNewMacro(vtkNeuralVolumeMapper);

using namespace vtkNeuralVolumeMapperDetail;


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
int vtkNeuralVolumeMapper::GetLastAccumulatedPaths() const
{
  return static_cast<int>(this->Internals->Stats.accumulatedPaths);
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
void vtkNeuralVolumeMapper::GetLastFrameTimings(double timings[FrameTimingCount]) const
{
  std::copy(this->Internals->Timings, this->Internals->Timings + FrameTimingCount, timings);
}
const char* vtkNeuralVolumeMapper::GetLastDisplayPath() const
{
  return this->Internals->DisplayPath.c_str();
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
void vtkNeuralVolumeMapper::Fail(const std::string& message, bool report)
{
  vtkInternals& in = *this->Internals;
  in.LastError = message;
  in.HaveImage = false;
  in.WorkPending = false;
  in.Compositor.Clear();
  if (report && message != in.Reported)
  {
    vtkErrorMacro("Neural Volume: " << message);
    in.Reported = message;
  }
}

bool vtkNeuralVolumeMapper::UpdateSession(vtkImageData* image)
{
  vtkInternals& in = *this->Internals;
  vtkUnsignedCharArray* network = image ? vtkNeuralNetworkArray::Find(image->GetFieldData()) : nullptr;
  if (!network)
  {
    // The representation reports a missing network to the user (once per input).
    in.Session.reset();
    in.NetworkArray = nullptr;
    this->Fail(std::string("the input has no '") + vtkNeuralNetworkArray::GetArrayName() + "' field data array", false);
    return false;
  }
  if (network == in.NetworkArray && network->GetMTime() == in.NetworkTime && in.Session)
  {
    return true;
  }
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
    this->Fail(std::string("cannot use the input's network: ") + e.what(), true);
    return false;
  }
  catch (...)
  {
    this->Fail("cannot use the input's network", true);
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::Render(vtkRenderer* ren, vtkVolume* vol)
{
  vtkInternals& in = *this->Internals;
  const bool interactive =
    ren && ren->GetRenderWindow() && ren->GetRenderWindow()->GetDesiredUpdateRate() > 1.0 && !ren->GetSelector();
  if (interactive)
  {
    this->PaceInteractiveFrame(); // before the frame's clock: LastFrameTimings is the frame's work, not the wait
  }
  const auto frameStart = std::chrono::steady_clock::now();
  std::fill(in.Timings, in.Timings + FrameTimingCount, 0.0);
  // Hardware selection passes draw ids, not colours: the volume takes no part in them.
  if (!ren || !vol || !ren->GetRenderWindow() || ren->GetSelector())
  {
    return;
  }
  if (this->GetInputAlgorithm())
  {
    this->GetInputAlgorithm()->Update();
  }
  vtkImageData* image = vtkImageData::SafeDownCast(this->GetInput());
  if (!this->UpdateSession(image))
  {
    return; // draw nothing on failure (said once)
  }
  try
  {
    int vw = 0, vh = 0, vx = 0, vy = 0;
    ren->GetTiledSizeAndOrigin(&vw, &vh, &vx, &vy);
    if (vw < 1 || vh < 1)
    {
      return;
    }
    const double scale = interactive ? std::max(0.05, this->InteractiveImageScale * in.DetailFactor) : 1.0;
    nv::RenderRequest q;
    const std::string refused = this->BuildRequest(ren, vol, image, interactive, scale, q);
    if (!refused.empty())
    {
      this->Fail(refused, true);
      return;
    }
    this->ReadSceneDepth(ren, vol, q);
    bool drawn = false;
    if (this->Progressive() && in.Session->device() == nv::Device::Cpu && !in.WorkerRefused)
    {
      // In the background: this render only starts or continues the work and draws the newest image.
      std::string error;
      drawn = this->RenderProgressive(q, interactive, scale, error);
      if (!drawn && !in.WorkerRefused)
      {
        this->Fail(error, true);
        return;
      }
    }
    if (!drawn)
    {
      this->RenderBlocking(ren, q, interactive, scale); // (also when the worker was just refused)
    }
    in.LastError.clear();
    in.Reported.clear();
  }
  catch (const std::bad_alloc&)
  {
    this->Fail("rendering failed: out of memory (lower DecodeResolution or the view's size)", true);
    return;
  }
  catch (const std::exception& e)
  {
    this->Fail(std::string("rendering failed: ") + e.what(), true);
    return;
  }
  catch (...)
  {
    // Nothing may leave a render: ParaView would abort and lose the session.
    this->Fail("rendering failed (unexpected error)", true);
    return;
  }
  this->DrawImage(ren, frameStart);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::PaceInteractiveFrame()
{
  // Slots on a steady cadence (slot k = first + k periods): a frame that comes a little late takes its slot anyway
  // and the next keeps the cadence, so a turning view averages the full rate instead of losing each late frame's
  // delay; a frame later than a whole slot (the view was still) starts a new cadence.
  vtkInternals& in = *this->Internals;
  const auto now = std::chrono::steady_clock::now();
  if (this->MaximumInteractiveFrameRate <= 0.0)
  {
    in.NextInteractiveSlot = {};
    in.DetailFactor = in.Detail.next(0.0, 0.0, 0.0); // unpaced: full detail
    return;
  }
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
    std::chrono::duration<double>(1.0 / this->MaximumInteractiveFrameRate));
  const bool cadence = in.NextInteractiveSlot.time_since_epoch().count() != 0;
  // How late this frame is for its slot (negative: early), for the interactive image's level of detail; NaN when the
  // view was still before it (no interactive frame for a quarter of a second: not a late frame).
  double lateSeconds = std::numeric_limits<double>::quiet_NaN();
  const bool turning = now - in.LastInteractiveFrame < std::chrono::milliseconds(250);
  in.LastInteractiveFrame = now;
  if (cadence && now < in.NextInteractiveSlot)
  {
    lateSeconds = -std::chrono::duration<double>(in.NextInteractiveSlot - now).count();
    std::this_thread::sleep_until(in.NextInteractiveSlot);
    in.NextInteractiveSlot += period;
  }
  else if (cadence && now < in.NextInteractiveSlot + period)
  {
    lateSeconds = std::chrono::duration<double>(now - in.NextInteractiveSlot).count();
    in.NextInteractiveSlot += period;
  }
  else
  {
    if (cadence && turning)
      lateSeconds = std::chrono::duration<double>(now - in.NextInteractiveSlot).count(); // a slow frame
    in.NextInteractiveSlot = now + period;
  }
  // The previous frame's engine time: its GPU time (through interop, the frame before's), or the engine call's.
  const double engineSeconds = std::max(in.Timings[1], in.Timings[7]) / 1000.0;
  in.DetailFactor = this->AdaptiveInteractiveScale
    ? in.Detail.next(lateSeconds, engineSeconds, 1.0 / this->MaximumInteractiveFrameRate)
    : 1.0;
}

//------------------------------------------------------------------------------
uint64_t vtkNeuralVolumeMapper::SceneKey(const nv::RenderRequest& q) const
{
  // Everything that changes the picture: the engine's own key plus the network's session; an interactive picture may
  // show an older version's grid (liveRefreshMilliseconds), so it never stands for a still one.
  return Mix(Mix(nv::renderKey(q), reinterpret_cast<uintptr_t>(this->Internals->Session.get())),
    q.liveRefreshMilliseconds > 0.0 ? 1u : 0u);
}

bool vtkNeuralVolumeMapper::RenderProgressive(
  const nv::RenderRequest& q, bool interactive, double scale, std::string& error)
{
  const uint64_t sceneKey = this->SceneKey(q);
  const uint64_t key = Mix(sceneKey, this->Internals->Session->version());
  const bool pathTracing = static_cast<int>(q.shading) >= PATH_TRACING;
  const int frames = pathTracing && !interactive
    ? std::max(1, (this->TargetSamples + q.samplesPerPixel - 1) / q.samplesPerPixel)
    : 1;
  return this->RenderInBackground(q, Mix(key, static_cast<uint64_t>(frames)),
    Mix(sceneKey, static_cast<uint64_t>(frames)), frames, scale, error);
}

void vtkNeuralVolumeMapper::RenderBlocking(
  vtkRenderer* ren, const nv::RenderRequest& q, bool interactive, double scale)
{
  vtkInternals& in = *this->Internals;
  nv::NetworkSession& session = *in.Session;
  const uint64_t key = Mix(this->SceneKey(q), session.version());
  const bool pathTracing = static_cast<int>(q.shading) >= PATH_TRACING;
  if (in.Worker)
  {
    in.Worker->Cancel(); // back to blocking renders (ProgressiveRefinement turned off, or a screenshot)
  }
  in.ImageScale = scale;
  in.ImageLevel = 0;
  in.ImageLevels = 1;
  in.ImageFinal = true;
  in.Progress = 1.0;
  auto accumulated = [&]() { return in.Stats.accumulatedPaths; };
  const bool same = in.HaveImage && key == in.Key;
  // A new picture; or the same one whose refined decode grid may be ready (else the engine returns the same image);
  // or one more path-tracing frame into the average.
  const bool render =
    !same || in.Stats.decodePending || (pathTracing && !interactive && accumulated() < this->TargetSamples);
  if (render)
  {
    this->RenderOnce(ren, q, key);
    if (!this->Progressive() && !interactive)
    {
      this->FinishStillPicture(ren, q, key);
    }
  }
  in.WorkPending = in.Stats.decodePending || session.workPending() ||
    (pathTracing && !interactive && accumulated() < this->TargetSamples);
}

void vtkNeuralVolumeMapper::RenderOnce(vtkRenderer* ren, const nv::RenderRequest& q, uint64_t key)
{
  vtkInternals& in = *this->Internals;
  this->RenderToCompositor(ren, q);
  if (!in.Result.stats.reused)
  {
    ++in.EngineRenders; // the engine rendered (not only returned its previous image)
  }
  in.Stats = in.Result.stats;
  in.Size[0] = q.width;
  in.Size[1] = q.height;
  in.Key = key;
  in.HaveImage = true;
}

void vtkNeuralVolumeMapper::FinishStillPicture(vtkRenderer* ren, const nv::RenderRequest& q, uint64_t key)
{
  // A still render returns the final picture: wait for the refined grid, accumulate to the target. Each path-tracing
  // render traces as many paths per pixel as the accumulation holds already (1, 1, 2, 4, ... up to the target: 7
  // engine calls for 64 paths instead of 64; the accumulation continues across paths per render, and the denoiser's
  // variance sees every render as a frame).
  vtkInternals& in = *this->Internals;
  const bool pathTracing = static_cast<int>(q.shading) >= PATH_TRACING;
  const auto waitStart = std::chrono::steady_clock::now();
  nv::RenderRequest next = q;
  for (int guard = 0; guard < (1 << 24); ++guard)
  {
    if (in.Stats.decodePending)
    {
      // The engine keeps workPending() until a render hands the refined grid out: render again until the picture
      // no longer uses a coarse grid. Nothing running, or too long: keep the coarse picture.
      if (!in.Session->workPending())
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
    }
    else if (!pathTracing || in.Stats.accumulatedPaths >= this->TargetSamples)
    {
      break;
    }
    else
    {
      const int64_t remaining = this->TargetSamples - in.Stats.accumulatedPaths;
      const int64_t paths = std::max<int64_t>(q.samplesPerPixel, in.Stats.accumulatedPaths);
      next.samplesPerPixel = static_cast<int>(std::min<int64_t>({ remaining, paths, 4096 }));
    }
    this->RenderOnce(ren, next, key);
  }
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
    in.Timings[3] = -1.0; // uploaded by Draw()
    in.DisplayPath = "host copy";
    in.HaveImage = true;
    in.Key = 0; // a blocking render after this one renders its own picture
  }
  in.Progress = worker.Progress();
  in.WorkPending = busy || resting || worker.WaitForImage(0.0);
  return true;
}

void vtkNeuralVolumeMapper::DrawImage(vtkRenderer* ren, std::chrono::steady_clock::time_point frameStart)
{
  vtkInternals& in = *this->Internals;
  try
  {
    in.Compositor.Draw(ren);
    if (in.Timings[3] < 0.0)
    {
      in.Timings[3] = in.Compositor.GetUploadMilliseconds(); // a new host image was uploaded by Draw()
    }
    in.Timings[4] = in.Compositor.GetDrawMilliseconds();
    in.Timings[5] = MillisecondsSince(frameStart);
    if (this->Progressive() && in.Worker && in.Worker->Busy() &&
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
     << indent << "Denoise: " << this->Denoise << "\n"
     << indent << "FollowViewLight: " << this->FollowViewLight << "\n"
     << indent << "LightDirection: " << this->LightDirection[0] << " " << this->LightDirection[1] << " "
     << this->LightDirection[2] << "\n"
     << indent << "EmptySpaceSkipping: " << this->EmptySpaceSkipping << "\n"
     << indent << "DecodeResolution: " << this->DecodeResolution[0] << " " << this->DecodeResolution[1] << " "
     << this->DecodeResolution[2] << "\n"
     << indent << "InteractiveImageScale: " << this->InteractiveImageScale << "\n"
     << indent << "AdaptiveInteractiveScale: " << this->AdaptiveInteractiveScale << "\n"
     << indent << "MaximumInteractiveFrameRate: " << this->MaximumInteractiveFrameRate << "\n"
     << indent << "ProgressiveRefinement: " << this->ProgressiveRefinement << "\n"
     << indent << "FinalPictureRequired: " << this->FinalPictureRequired << "\n"
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
