// Private to NeuralVolume::Filters: the field Neural Compress trains from, made ready (resampled, read, probed,
// hashed) in a background thread, so that Apply returns at once while a large input is prepared.
#ifndef vtkNeuralCompressPreparation_h
#define vtkNeuralCompressPreparation_h

#include "vtkNeuralCompressJob.h"

#include "vtkSmartPointer.h"
#include "vtkType.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

class vtkDataArray;
class vtkDataObject;

namespace vtkNeuralCompressInternals
{

/// What the filter's thread reads from the pipeline for one execution (cheap); the rest is prepared from it.
struct InputRequest
{
  vtkSmartPointer<vtkDataObject> Object; ///< the input (a shallow copy when prepared in the background)
  vtkSmartPointer<vtkDataArray> Array;   ///< image inputs: the selected array
  std::string ArrayName;                 ///< other inputs: the array to resample
  int Association = -1;
  int AnnouncedDims[3] = { 0, 0, 0 }; ///< the sampling dimensions RequestInformation announced (0: none)
  bool IsImage = false;
  /// An out-of-core reader's output (vtkNeuralOutOfCoreInput.h): the file it names and the array asked for; the
  /// path is empty for every other input.
  std::string OutOfCorePath, OutOfCoreArray;
  /// The out-of-core image's extent (sample indices of the file): the whole file, or under MPI the rank's padded
  /// piece (vtkNeuralCompressPartition.h), the only part of the file this rank reads.
  int OutOfCoreExtent[6] = { 0, -1, 0, -1, 0, -1 };
  /// MPI, a rank's piece: the extent it owns and the whole extent (FieldInfo::PieceOwned); empty otherwise.
  int PieceOwned[6] = { 0, -1, 0, -1, 0, -1 };
  int PieceWhole[6] = { 0, -1, 0, -1, 0, -1 };
  const void* Source = nullptr; ///< the pipeline's input object (Object may be a copy of it)
  /// Images: the input's modification time; other inputs: InputStamp (vtkNeuralCompressResample.h), also the
  /// resampler's cache key.
  uint64_t InputMTime = 0;
};

/// What decides a preparation: a new one starts when any of these differs.
struct InputIdentity
{
  const void* Object = nullptr;
  const void* ArrayObject = nullptr; ///< images: the selected array
  uint64_t MTime = 0; ///< the selected array's modification time (images) or InputStamp
  std::string Array;
  int Association = -1;
  std::string Settings; ///< Settings::Canonical()
  double Time = 0.0;
  bool operator==(const InputIdentity& other) const
  {
    return this->Object == other.Object && this->ArrayObject == other.ArrayObject && this->MTime == other.MTime &&
      this->Array == other.Array &&
      this->Association == other.Association && this->Settings == other.Settings && this->Time == other.Time;
  }
  bool operator!=(const InputIdentity& other) const { return !(*this == other); }
};

/// The training field of one input, ready for a job.
struct PreparedField
{
  FieldInfo Field;
  std::shared_ptr<TrainingData> Data;
  Settings TrainingSettings; ///< the filter's settings when the preparation started
  uint64_t Key = 0;
};

/// A message for the output window, queued by the preparation's thread and printed by the filter's.
struct QueuedMessage
{
  enum Level
  {
    Error,
    Warning,
    Text
  };
  Level Kind = Error;
  std::string Body;
};

/// One preparation running in a thread of its own. The filter's thread polls Done(), then takes the result and the
/// messages. A newer preparation first cancels and joins the one it replaces, in its own thread, so the filter's
/// thread never waits for either.
class Preparation
{
public:
  /// The work: fills Result(); false after queueing an error (or when cancelled).
  using Work = std::function<bool(Preparation&)>;

  Preparation(const InputIdentity& identity, Work work, std::unique_ptr<Preparation> previous);
  ~Preparation(); ///< cancels and joins
  Preparation(const Preparation&) = delete;
  Preparation& operator=(const Preparation&) = delete;

  /// The preparation whose work runs in the calling thread, or null (the filter's thread).
  static Preparation* OfThisThread();

  const InputIdentity& Identity() const { return this->Id; }
  bool Done() const { return this->Finished.load(); }
  /// Done and its work succeeded.
  bool Succeeded() const { return this->Finished.load() && this->Ok; }
  /// Blocks until Done().
  void Wait();
  /// Blocks until Done() or `seconds` have passed; returns Done().
  bool WaitFor(double seconds);
  void Cancel() { this->CancelRequested = true; }
  bool Cancelled() const { return this->CancelRequested.load(); }

  /// What the work is doing now ("resampling the input onto 128^3"), for the status line.
  void SetStage(const std::string& stage);
  /// "Preparing: <stage>, 2.1 s".
  std::string StatusLine() const;
  /// Seconds since the preparation was created (the Apply that asked for it).
  double Seconds() const;
  /// Changes whenever the stage changes or the work ends (the live-source poll refreshes the panel on it).
  uint64_t Serial() const { return this->SerialCount.load(); }

  void Queue(QueuedMessage::Level level, const std::string& body);
  std::vector<QueuedMessage> TakeMessages();

  PreparedField& Result() { return this->Prepared; }
  /// A resampled input's bounds (set by the filter's thread before the work starts; Bounds[0] > Bounds[1]: none).
  double Bounds[6] = { 1.0, -1.0, 1.0, -1.0, 1.0, -1.0 };
  bool Adopted = false; ///< the filter's thread took the result (a job started from it, or its error printed)

private:
  void Main(Work work, std::unique_ptr<Preparation> previous);

  InputIdentity Id;
  PreparedField Prepared;
  std::chrono::steady_clock::time_point Started;
  std::atomic<bool> Finished{ false };
  std::atomic<bool> CancelRequested{ false };
  std::atomic<uint64_t> SerialCount{ 0 };
  bool Ok = false;
  mutable std::mutex Mutex;
  std::condition_variable Ended;
  std::string Stage;
  std::vector<QueuedMessage> Messages;
  std::thread Thread;
};

} // namespace vtkNeuralCompressInternals

#endif
