/**
 * @class   vtkNeuralVolumeMapper
 * @brief   volume mapper that renders a trained neural network with the NeuralVolume engine
 *
 * The input is a vtkImageData whose field data carries a network (`NeuralNetwork`, written by
 * vtkNeuralCompress; see vtkNeuralNetworkArray). Each render gathers an engine request from VTK's
 * state -- the camera's view-projection for the renderer's tiled viewport, the volume's matrix and
 * the image's direction (world -> network coordinates), the colour and scalar-opacity functions of
 * the vtkVolumeProperty sampled over their range, its unit distance, Shade, Ambient, Diffuse,
 * Specular, SpecularPower and scattering anisotropy, the blend mode, the view's key light, and the
 * window depth of the opaque geometry already drawn -- renders it with the network's session
 * (the session the filter trained when it lives in this process) and composites the premultiplied
 * RGBA image over the framebuffer as a textured quad.
 *
 * Nothing is rendered again while the request, the depth buffer and the network are unchanged: the
 * last image is drawn again (path tracing instead accumulates one more frame until TargetSamples
 * paths per pixel). An interactive render (render window desired update rate > 1, ParaView's
 * InteractiveRender) renders InteractiveImageScale of the viewport with one path per pixel.
 *
 * Still renders block until the picture is final (the Decode path's full grid, decoded at once on all
 * the session's threads -- finishing a background decode an interactive render started -- and path
 * tracing at TargetSamples) unless ProgressiveRefinement is on (the GUI turns it on). Then, on the
 * CPU engine, no render waits for the engine: a new picture (camera, transfer function, network,
 * view size...) is rendered by a background thread (vtkNeuralProgressiveRenderer), first at a
 * reduced size chosen from the measured cost per ray to take about FrameBudget milliseconds (a render
 * waits at most 1.5 x FrameBudget for it), then at twice the size per axis up to the full size, then
 * path-tracing frames up to TargetSamples; each render draws the newest finished image (and a thin
 * progress bar along the bottom once a refinement has run 0.3 s), and another picture cancels the
 * work in flight (the engine stops within a pixel or an inference slice). On the CUDA engine a
 * render does one refinement step. GetWorkPending() says that another render would show more (the
 * GUI's refresh driver, vtkNeuralVolumeRefreshDriver, renders again while it is true).
 *
 * Engine errors are reported once with vtkErrorMacro and nothing is drawn.
 */
#ifndef vtkNeuralVolumeMapper_h
#define vtkNeuralVolumeMapper_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkVolumeMapper.h"

#include <chrono>  // for the frame timings
#include <cstdint> // for uint64_t
#include <memory>  // for std::unique_ptr
#include <string>  // for std::string

class vtkFloatArray;
class vtkImageData;
class vtkVolumeProperty;
namespace nv
{
struct RenderRequest;
class NetworkSession;
enum class BlendMode : int;
}

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralVolumeMapper : public vtkVolumeMapper
{
public:
  static vtkNeuralVolumeMapper* New();
  vtkTypeMacro(vtkNeuralVolumeMapper, vtkVolumeMapper);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /// The data this mapper renders is the network (field data `NeuralNetwork`), whatever scalar array
  /// ParaView selects for the colour map: a decoded field may be absent (OutputMode "Network only").
  /// ParaView's volume prop (vtkPVLODVolume) renders a volume mapper only when these name an array
  /// of its input.
  int GetScalarMode() override;
  int GetArrayAccessMode() override;
  char* GetArrayName() override;
  ///@}

  /// Values as in the engine (nv::RenderPath, nv::ShadingMode).
  enum RenderPaths
  {
    DECODE = 0,
    SAMPLE_STREAMING = 1,
    IN_SHADER = 2
  };
  enum ShadingModes
  {
    RAY_MARCHING = 0,
    RAY_MARCHING_GRADIENT = 1,
    RAY_MARCHING_SHADOWS = 2,
    PATH_TRACING = 3,
    PATH_TRACING_NEE = 4
  };

  ///@{
  /// How the network is evaluated: Decode (decoded to a grid, refined in the background), Sample
  /// Streaming (wavefronts of K samples per ray, batched inference) or In-Shader (network inside
  /// the marching loop).
  vtkSetClampMacro(RenderPath, int, DECODE, IN_SHADER);
  vtkGetMacro(RenderPath, int);
  ///@}

  ///@{
  /// Light transport. Ray Marching with the volume property's Shade on is gradient shading.
  vtkSetClampMacro(ShadingMode, int, RAY_MARCHING, PATH_TRACING_NEE);
  vtkGetMacro(ShadingMode, int);
  ///@}

  ///@{
  /// World distance between samples; 0 = one sample per voxel of the trained field.
  vtkSetClampMacro(SampleDistance, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(SampleDistance, double);
  ///@}

  ///@{
  /// Sample Streaming: samples each ray advances per wavefront (K); 0 = the engine's default.
  vtkSetClampMacro(StreamingSamples, int, 0, 1024);
  vtkGetMacro(StreamingSamples, int);
  ///@}

  ///@{
  /// Path tracing: paths per pixel per render, scattering events per path, and the paths per pixel
  /// a still view accumulates to.
  vtkSetClampMacro(SamplesPerPixel, int, 1, 4096);
  vtkGetMacro(SamplesPerPixel, int);
  vtkSetClampMacro(MaxBounces, int, 0, 1024);
  vtkGetMacro(MaxBounces, int);
  vtkSetClampMacro(TargetSamples, int, 1, 1 << 20);
  vtkGetMacro(TargetSamples, int);
  ///@}

  ///@{
  /// Path tracing: hand out the accumulation denoised (nv::RenderRequest::denoise: an edge-avoiding filter guided by
  /// the ray-marched picture of the same view; the accumulation itself stays unfiltered). On by default.
  vtkSetMacro(Denoise, bool);
  vtkGetMacro(Denoise, bool);
  vtkBooleanMacro(Denoise, bool);
  ///@}

  ///@{
  /// The light: the view's key light (FollowViewLight on, the default) or LightDirection (world
  /// space, towards the light).
  vtkSetMacro(FollowViewLight, bool);
  vtkGetMacro(FollowViewLight, bool);
  vtkSetVector3Macro(LightDirection, double);
  vtkGetVector3Macro(LightDirection, double);
  ///@}

  ///@{
  /// Skip empty macrocells (and use local majorants for path tracing). Does not change the picture.
  vtkSetMacro(EmptySpaceSkipping, bool);
  vtkGetMacro(EmptySpaceSkipping, bool);
  ///@}

  ///@{
  /// Decode path: samples per axis of the decoded grid; 0 0 0 = the trained field's dimensions.
  vtkSetVector3Macro(DecodeResolution, int);
  vtkGetVector3Macro(DecodeResolution, int);
  ///@}

  ///@{
  /// Fraction of the viewport size rendered by an interactive render (0.05 - 1).
  vtkSetClampMacro(InteractiveImageScale, double, 0.05, 1.0);
  vtkGetMacro(InteractiveImageScale, double);
  /// Paced interactive renders (MaximumInteractiveFrameRate > 0) that keep missing their slot while the engine's time
  /// is a large part of it render a smaller image (0.7 then 0.5 of InteractiveImageScale per axis), and a larger one
  /// again once frames have time to spare (nv::InteractiveDetail). Still renders are always full size. Default on.
  vtkSetMacro(AdaptiveInteractiveScale, bool);
  vtkGetMacro(AdaptiveInteractiveScale, bool);
  ///@}

  ///@{
  /// Interactive renders at most this many a second (a display's rate; 0: as fast as they come): one that comes
  /// sooner waits for its slot, so the GPU's time between frames is the training's while a network trains beside the
  /// view. Still renders are never held.
  vtkSetClampMacro(MaximumInteractiveFrameRate, double, 0.0, 1000.0);
  vtkGetMacro(MaximumInteractiveFrameRate, double);
  ///@}

  ///@{
  /// Off (default): a still render returns the final picture. On: renders never wait for the engine
  /// beyond about FrameBudget; the picture refines in the background (see above).
  vtkSetMacro(ProgressiveRefinement, bool);
  vtkGetMacro(ProgressiveRefinement, bool);
  ///@}

  ///@{
  /// On: still renders return the final picture even with ProgressiveRefinement, for the image of the requested size
  /// and camera (the representation sets it while the view captures a screenshot: Save Screenshot, SaveScreenshot()).
  vtkSetMacro(FinalPictureRequired, bool);
  vtkGetMacro(FinalPictureRequired, bool);
  ///@}

  ///@{
  /// Progressive mode: milliseconds the first image of a new picture should take (5 - 1000, default 50).
  vtkSetClampMacro(FrameBudget, double, 5.0, 1000.0);
  vtkGetMacro(FrameBudget, double);
  ///@}

  ///@{
  /// On (default): where the engine renders on the GPU and the view's OpenGL runs on that NVIDIA GPU, the image goes
  /// from the engine's GPU memory into the view's texture through CUDA-OpenGL interop (no copy through the host);
  /// elsewhere, or off, it is copied to the host and uploaded. GetLastDisplayPath says which one the last frame took.
  vtkSetMacro(CudaGLInterop, bool);
  vtkGetMacro(CudaGLInterop, bool);
  ///@}

  ///@{
  /// Where the last frame's time went, wall milliseconds in the render thread: [0] reading the view's depth buffer
  /// (0 when no opaque geometry is shown), [1] the engine's render call (kernels, or CPU rays, and the copy of the
  /// image to the host), [2] of which the copy to the host (GPU engine), [3] the image's way into the texture (the
  /// upload of a host image, or the interop copy), [4] drawing the blended quad, [5] the whole mapper Render; inside
  /// [1]: [6] the engine's preparation (decode, macrocells, uploads), [7] its rendering (GPU: kernel time by CUDA
  /// events). [1] - [6] - [7] is the call's own overhead (locks, launches, synchronisation).
  static constexpr int FrameTimingCount = 8;
  void GetLastFrameTimings(double timings[FrameTimingCount]) const;
  /// "CUDA-OpenGL interop", "host copy", or "host copy (interop: <reason>)" for the last frame.
  const char* GetLastDisplayPath() const;
  ///@}

  ///@{
  /// About the last render: the path the engine ran, field evaluations, evaluations of a plain
  /// marcher (no skipping), Sample Streaming wavefronts, path-tracing frames accumulated, the image
  /// size, whether the Decode path showed a coarser grid, and the engine's render time.
  int GetLastRenderPath() const;
  double GetLastSamplesEvaluated() const;
  double GetLastSamplesPlain() const;
  double GetLastWavefronts() const;
  int GetLastAccumulatedFrames() const;
  int GetLastAccumulatedPaths() const; ///< paths per pixel in the last path-traced image (frames x their paths)
  void GetLastImageSize(int size[2]) const;
  bool GetLastDecodePending() const;
  double GetLastRenderMilliseconds() const;
  ///@}

  /// session->render() calls so far (a render that reuses the last image does not count).
  int GetEngineRenderCount() const;
  /// True when another render would refine the picture (background decode still running, or path
  /// tracing below TargetSamples, or a progressive refinement running or not shown yet).
  bool GetWorkPending() const;

  ///@{
  /// The image drawn: its size relative to the viewport per axis (1 for a final still picture,
  /// InteractiveImageScale for an interactive one, less for a progressive refinement's early images),
  /// its refinement level (0 the first image of a picture) out of GetLastRefinementLevels(), and
  /// whether nothing would refine it. GetLastImage copies it (premultiplied RGBA floats, row 0 at the
  /// bottom, GetLastImageSize pixels).
  double GetLastImageScale() const;
  int GetLastRefinementLevel() const;
  int GetLastRefinementLevels() const;
  bool GetLastImageFinal() const;
  void GetLastImage(vtkFloatArray* rgba) const;
  ///@}

  ///@{
  /// Progressive mode: the fraction of the current refinement's rays finished; refinements abandoned
  /// for another picture before they finished; engine renders those cancellations stopped; and the
  /// milliseconds the last abandoned render took to stop after it was cancelled.
  double GetRefinementProgress() const;
  int GetAbandonedRefinements() const;
  int GetCancelledEngineRenders() const;
  double GetLastAbandonMilliseconds() const;
  ///@}
  /// True when the input carries a network the engine accepted.
  bool HasNetwork() const;
  /// True when the network's session was created from the serialized bytes (not the session the
  /// Neural Compress filter of this process trained).
  bool GetSessionFromBytes() const;
  /// Last error reported ("" when the last render succeeded).
  const char* GetLastError() const;

  void Render(vtkRenderer* ren, vtkVolume* vol) override;
  void ReleaseGraphicsResources(vtkWindow*) override;

protected:
  vtkNeuralVolumeMapper();
  ~vtkNeuralVolumeMapper() override;

  int RenderPath = DECODE;
  int ShadingMode = RAY_MARCHING;
  double SampleDistance = 0.0;
  int StreamingSamples;
  int SamplesPerPixel = 1;
  int MaxBounces = 4;
  int TargetSamples = 64;
  bool Denoise = true;
  bool FollowViewLight = true;
  double LightDirection[3] = { 0.0, 0.0, 1.0 };
  bool EmptySpaceSkipping = true;
  int DecodeResolution[3] = { 0, 0, 0 };
  double InteractiveImageScale = 0.5;
  bool AdaptiveInteractiveScale = true;
  double MaximumInteractiveFrameRate = 60.0;
  bool ProgressiveRefinement = false;
  bool FinalPictureRequired = false;
  /// ProgressiveRefinement unless a final picture is required now.
  bool Progressive() const { return this->ProgressiveRefinement && !this->FinalPictureRequired; }
  double FrameBudget = 50.0;
  bool CudaGLInterop = true;

private:
  vtkNeuralVolumeMapper(const vtkNeuralVolumeMapper&) = delete;
  void operator=(const vtkNeuralVolumeMapper&) = delete;

  /// Progressive mode: start `request` in the background unless it is the picture in progress (key) or a refinement
  /// of the same scene (sceneKey: the key without the network's version) is in flight, take the newest finished
  /// image. False (and `error`) when the background render failed.
  bool RenderInBackground(const nv::RenderRequest& request, uint64_t key, uint64_t sceneKey, int frames,
    double viewScale, std::string& error);
  /// Draw nothing on failure: forget the last image and say why once (`report`: as an error).
  void Fail(const std::string& message, bool report);
  /// The session of the input's network (made again when the array changes). False (after Fail) without one.
  bool UpdateSession(vtkImageData* image);
  /// The picture's key without the network's version (a training network publishes new versions of one scene).
  /// Holds an interactive frame that comes sooner than MaximumInteractiveFrameRate allows until its slot.
  void PaceInteractiveFrame();
  uint64_t SceneKey(const nv::RenderRequest& q) const;
  /// Progressive mode (CPU engine): the background renderer's newest image of `q` (RenderInBackground).
  bool RenderProgressive(const nv::RenderRequest& q, bool interactive, double scale, std::string& error);
  /// The engine renders `q` in this thread unless the image is that of `q` already; a still render waits for the
  /// full decode grid and accumulates path tracing to TargetSamples (FinishStillPicture).
  void RenderBlocking(vtkRenderer* ren, const nv::RenderRequest& q, bool interactive, double scale);
  void RenderOnce(vtkRenderer* ren, const nv::RenderRequest& q, uint64_t key);
  void FinishStillPicture(vtkRenderer* ren, const nv::RenderRequest& q, uint64_t key);
  /// Composite the current image (and the progress bar of a long refinement).
  void DrawImage(vtkRenderer* ren, std::chrono::steady_clock::time_point frameStart);
  /// The engine request of this frame from the renderer, the volume and this mapper's settings (without the depth
  /// buffer). "" on success, else why the volume cannot be drawn.
  std::string BuildRequest(vtkRenderer* ren, vtkVolume* vol, vtkImageData* image, bool interactive, double scale,
    nv::RenderRequest& q);
  /// BuildRequest's steps: the transfer function sampled from the volume's property (refused, with why, for a
  /// value range wider than the largest double), then the path, shading, lighting and sampling settings.
  std::string RequestTransferFunction(vtkVolume* vol, nv::RenderRequest& q);
  void RequestShading(vtkRenderer* ren, vtkVolumeProperty* property, bool interactive, nv::RenderRequest& q);
  /// MPI: the coarse grid of the whole field for the shading modes with secondary rays (shadows, path tracing).
  void RequestSurroundings(vtkImageData* image, nv::RenderRequest& q);
  /// The engine's blend mode for BlendMode (Isosurface and Slice: Composite, with a warning once).
  nv::BlendMode EngineBlendMode();
  /// The Decode path's grid for DecodeResolution and this machine (a warning when it is clamped).
  void FitDecodeGrid();
  /// A warning (once per network) when the network has error-bound corrections that this request's path does not
  /// apply.
  void WarnUnboundedPicture(nv::NetworkSession& session, const nv::RenderRequest& q);
  /// The depth of the opaque geometry already drawn, when there is any (q.depth), else q.depth stays null.
  void ReadSceneDepth(vtkRenderer* ren, vtkVolume* vol, nv::RenderRequest& q);
  /// One engine render of `q` into the compositor: on the GPU through CUDA-OpenGL interop where possible.
  void RenderToCompositor(vtkRenderer* ren, const nv::RenderRequest& q);

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
};

#endif
