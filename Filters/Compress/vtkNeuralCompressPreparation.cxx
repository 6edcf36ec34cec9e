#include "vtkNeuralCompressPreparation.h"

#include <exception>
#include <new>
#include <sstream>
#include <system_error>

namespace vtkNeuralCompressInternals
{
namespace
{
thread_local Preparation* ThisThreadPreparation = nullptr;
}

Preparation::Preparation(const InputIdentity& identity, Work work, std::unique_ptr<Preparation> previous)
  : Id(identity)
  , Started(std::chrono::steady_clock::now())
{
  if (previous)
    previous->Cancel();
  Preparation* replaced = previous.release(); // ends in Main, in whichever thread runs it
  try
  {
    this->Thread = std::thread([this, work, replaced]() { this->Main(work, std::unique_ptr<Preparation>(replaced)); });
  }
  catch (const std::system_error&)
  {
    // The system gives no thread (its limit on threads or memory): prepared in the caller's thread, as a blocking
    // execution would.
    this->Main(std::move(work), std::unique_ptr<Preparation>(replaced));
  }
}

Preparation::~Preparation()
{
  this->Cancel();
  if (this->Thread.joinable())
    this->Thread.join();
}

Preparation* Preparation::OfThisThread()
{
  return ThisThreadPreparation;
}

void Preparation::Main(Work work, std::unique_ptr<Preparation> previous)
{
  previous.reset(); // the one replaced ends first (it shares the filter's resampler)
  ThisThreadPreparation = this;
  bool ok = false;
  if (!this->Cancelled())
  {
    try
    {
      ok = work(*this);
    }
    catch (const std::bad_alloc&)
    {
      this->Queue(QueuedMessage::Error,
        "Neural Compress: out of memory while preparing the input. Lower SamplingDimensions, ProbePoints or "
        "OutputResolution. The output is empty.");
    }
    catch (const std::exception& e)
    {
      this->Queue(QueuedMessage::Error, std::string("Neural Compress: ") + e.what());
    }
    catch (...)
    {
      this->Queue(QueuedMessage::Error, "Neural Compress: unexpected failure while preparing the input.");
    }
  }
  ThisThreadPreparation = nullptr;
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    this->Ok = ok && !this->Cancelled();
    this->Finished = true;
    ++this->SerialCount;
  }
  this->Ended.notify_all();
}

void Preparation::Wait()
{
  std::unique_lock<std::mutex> lock(this->Mutex);
  this->Ended.wait(lock, [this]() { return this->Finished.load(); });
}

bool Preparation::WaitFor(double seconds)
{
  std::unique_lock<std::mutex> lock(this->Mutex);
  return this->Ended.wait_for(
    lock, std::chrono::duration<double>(seconds), [this]() { return this->Finished.load(); });
}

void Preparation::SetStage(const std::string& stage)
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->Stage = stage;
  ++this->SerialCount;
}

std::string Preparation::StatusLine() const
{
  std::ostringstream text;
  text.precision(3);
  std::lock_guard<std::mutex> lock(this->Mutex);
  text << "Preparing: " << (this->Stage.empty() ? "reading the input" : this->Stage) << ", " << this->Seconds()
       << " s";
  return text.str();
}

double Preparation::Seconds() const
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - this->Started).count();
}

void Preparation::Queue(QueuedMessage::Level level, const std::string& body)
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->Messages.push_back(QueuedMessage{ level, body });
}

std::vector<QueuedMessage> Preparation::TakeMessages()
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  std::vector<QueuedMessage> taken;
  taken.swap(this->Messages);
  return taken;
}

} // namespace vtkNeuralCompressInternals
