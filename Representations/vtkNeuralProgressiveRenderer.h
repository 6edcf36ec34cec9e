// Private to NeuralVolume::Representations: the background renderer of vtkNeuralVolumeMapper's progressive mode.
//
// One worker thread per mapper renders a job -- a request at its final size -- level by level: first a reduced
// image whose size is chosen from the measured cost per ray of earlier renders so that it fits the job's budget,
// then images twice as large per axis up to the final size, then (path tracing) more frames into the average, and
// for the Decode path the final image again once the background decode has the full grid. Each finished image is
// published for the GUI thread to take. Starting another job cancels the one in flight through the engine's
// nv::RenderControl (the CPU engine stops within a pixel or an inference slice). No VTK and no OpenGL here: the
// mapper draws on the GUI thread.
#ifndef vtkNeuralProgressiveRenderer_h
#define vtkNeuralProgressiveRenderer_h

#include "Core/NetworkSession.h"
#include "Core/Render.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

class vtkNeuralProgressiveRenderer
{
public:
  /// What to render.
  struct Job
  {
    std::shared_ptr<nv::NetworkSession> Session;
    nv::RenderRequest Request;     ///< at the final size; its depth and control are ignored
    std::vector<float> Depth;      ///< window depths at the final size (empty: none)
    uint64_t Key = 0;              ///< identifies the picture (the mapper's key)
    uint64_t SceneKey = 0;         ///< the same without the network's version (a network that trains)
    int Frames = 1;                ///< renders at the final size (path tracing: frames averaged)
    double BudgetMilliseconds = 50.0; ///< the first image should take at most this long
  };

  /// A finished image of the current job.
  struct Image
  {
    std::vector<float> Rgba; ///< premultiplied RGBA, Width * Height * 4, row 0 at the bottom
    int Width = 0;
    int Height = 0;
    double Scale = 1.0; ///< of the final size, per axis
    int Level = 0;      ///< 0: the first (coarsest) image of the job
    int Levels = 1;     ///< image sizes of the job (the last one is the final size)
    bool Final = false; ///< the job is complete: nothing would refine this picture
    nv::RenderStats Stats;
    uint64_t Key = 0;
  };

  vtkNeuralProgressiveRenderer();
  ~vtkNeuralProgressiveRenderer(); ///< cancels the job in flight and joins the worker
  vtkNeuralProgressiveRenderer(const vtkNeuralProgressiveRenderer&) = delete;
  vtkNeuralProgressiveRenderer& operator=(const vtkNeuralProgressiveRenderer&) = delete;

  /// Make `job` the current one; a job still in flight is cancelled (abandoned). Returns at once.
  void Start(Job&& job);
  /// Cancel the current job (no new one); returns at once.
  void Cancel();
  /// Key of the current job (0: none since the last Cancel()).
  uint64_t CurrentKey() const;
  /// The current job's SceneKey (0: none).
  uint64_t CurrentSceneKey() const;
  /// Wait at most `milliseconds` for an image of the current job not taken yet. True when there is one.
  bool WaitForImage(double milliseconds);
  /// Move out the newest image of the current job if it was not taken yet.
  bool TakeImage(Image& image);
  /// The current job's error message, once ("" when none).
  std::string TakeError();

  /// The current job is still rendering.
  bool Busy() const;
  /// Fraction of the current job's rays finished, in [0, 1].
  double Progress() const;
  /// Seconds since the current job started (0 when idle).
  double BusySeconds() const;
  /// True when the time since the last completed job lets the jobs take at most `shareOfTime` of the time (its
  /// duration against the rest since it ended); true when no job completed yet.
  bool RestedAfterLastJob(double shareOfTime) const;

  ///@{
  /// Counters: engine renders that drew (not cancelled, not reused), renders stopped by a cancellation, jobs
  /// abandoned before they finished, and the time the last abandoned render took to stop after its cancellation.
  int EngineRenders() const { return this->EngineRenderCount.load(); }
  int CancelledRenders() const { return this->CancelledRenderCount.load(); }
  int AbandonedJobs() const { return this->AbandonedJobCount.load(); }
  double LastAbandonMilliseconds() const { return this->AbandonMilliseconds.load(); }
  ///@}

private:
  /// Cancels the job in flight (Mutex held): its engine render stops, it counts as abandoned.
  void AbandonInFlight();
  using Clock = std::chrono::steady_clock;

  void Run();
  /// Renders the job's levels; returns when it is complete or cancelled.
  void RunJob(const Job& job, uint64_t serial, nv::RenderControl& control);
  /// One engine render of the job at `scale`; false when it was cancelled.
  bool RenderLevel(const Job& job, double scale, nv::RenderControl& control, std::vector<float>& depth,
    nv::RenderResult& result);
  /// Hand an image to the GUI thread (dropped when the job is no longer current).
  void Publish(uint64_t serial, nv::RenderResult& result, const nv::RenderRequest& request, double scale, int level,
    int levels, bool last);
  /// The worker noticed a cancellation: record how long it took.
  void NoteCancelled();
  /// Engine milliseconds per ray measured for this kind of render, or a guess.
  double CostPerRay(const nv::RenderRequest& request) const;

  mutable std::mutex Mutex;
  std::condition_variable Wake;      ///< the worker: a job or Stop
  std::condition_variable Published; ///< the GUI thread: an image or the end of a job
  bool Stopping = false;

  // The current job (guarded by Mutex).
  Job Next;
  bool HaveNext = false;
  uint64_t Serial = 0;       ///< of the current job
  uint64_t Key = 0;
  uint64_t SceneKey = 0;
  double LastJobSeconds = 0.0; ///< duration of the last job that ran to its end
  Clock::time_point LastJobEnd;
  bool Running = false;      ///< the current job has not finished
  Clock::time_point Started;
  std::shared_ptr<nv::RenderControl> Control; ///< of the job the worker runs
  Clock::time_point CancelTime;
  bool CancelPending = false;
  Image Latest;
  bool LatestFresh = false;
  std::string Error;

  int64_t TotalRays = 1; ///< of the current job (Control->raysFinished counts the finished ones)

  std::atomic<int> EngineRenderCount{ 0 };
  std::atomic<int> CancelledRenderCount{ 0 };
  std::atomic<int> AbandonedJobCount{ 0 };
  std::atomic<double> AbandonMilliseconds{ 0.0 };

  std::map<int, double> MillisecondsPerRay; ///< per path x shading mode (worker only)

  /// Declared last and started in the constructor's body: Run() reads every member above (Stopping and HaveNext at
  /// once), so the worker must not start before they are all constructed.
  std::thread Worker;
};

#endif
