// Private to NeuralVolume::Representations: the state vtkNeuralVolumeMapper keeps between frames (its network's
// session, the last image and what it shows, the progressive renderer, the last frame's timings), shared by the
// mapper's source files (vtkNeuralVolumeMapper.cxx: the frame; vtkNeuralVolumeMapperRequest.cxx: the engine request
// and call).
#ifndef vtkNeuralVolumeMapperInternals_h
#define vtkNeuralVolumeMapperInternals_h

#include "vtkNeuralVolumeMapper.h"

#include "vtkNeuralImageCompositor.h"
#include "vtkNeuralProgressiveRenderer.h"

#include "Core/InteractiveDetail.h"
#include "Core/NetworkSession.h"
#include "Core/Render.h"

#include "vtkType.h"

#include <chrono>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

class vtkUnsignedCharArray;
class vtkVolumeProperty;

namespace vtkNeuralVolumeMapperDetail
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
/// An interactive render of a network that changes while the view turns (training) keeps the decoded grid and the
/// macrocell ranges of an older version for up to this long (nv::RenderRequest::liveRefreshMilliseconds): the
/// Decode path re-decodes its grid ten times a second, not for every published version, while the view turns; a
/// still render derives them for the current version.
constexpr double kLiveRefreshMilliseconds = 100.0;
/// Progressive mode, a network that trains: the share of the time its live picture may take to redraw new versions.
constexpr double kLiveRenderShare = 0.5;
/// Progressive mode: the progress bar appears once a refinement has run this long.
constexpr double kProgressDelaySeconds = 0.3;

inline double MillisecondsSince(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

inline uint64_t Mix(uint64_t h, uint64_t v)
{
  h ^= v + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
  return h;
}
} // namespace vtkNeuralVolumeMapperDetail

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

  // MPI: the coarse grid of the whole field in this network's coordinates (RequestSurroundings), made again when the
  // image's array or the network changes.
  const void* SurroundingsArray = nullptr;
  vtkMTimeType SurroundingsTime = 0;
  const void* SurroundingsSession = nullptr;
  std::shared_ptr<const nv::SurroundingsGrid> Surroundings;

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
  const void* WarnedUnbounded = nullptr; ///< the corrections WarnUnboundedPicture warned about

  // The last frame: where its time went (GetLastFrameTimings) and how its image reached the view.
  double Timings[vtkNeuralVolumeMapper::FrameTimingCount] = {};
  std::chrono::steady_clock::time_point NextInteractiveSlot; ///< when the next interactive frame may start (pacing)
  std::chrono::steady_clock::time_point LastInteractiveFrame; ///< when the last paced interactive frame was asked for
  nv::InteractiveDetail Detail; ///< the interactive image's level of detail (AdaptiveInteractiveScale)
  double DetailFactor = 1.0;    ///< of InteractiveImageScale, for the current interactive frame
  std::string DisplayPath = "none";
  std::string InteropRefused; ///< why CUDA-OpenGL interop is not possible in this view ("" until it was refused)
};

#endif
