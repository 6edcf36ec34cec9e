// vtkNeuralCompress: the training controls, the live-source poll and the networks saved with a state.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressState.h"
#include "vtkNeuralCudaDevice.h"

#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/Serialization.h"

#include "vtkDataArray.h"
#include "vtkMultiProcessController.h"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdint>

//------------------------------------------------------------------------------
bool vtkNeuralCompress::GetNeedsUpdate()
{
  vtkMultiProcessController* c = nvi::DistributedController();
  if (c)
  {
    // MPI: ParaView asks rank 0 only, then updates every rank, and an execution ends with a collective: every rank
    // must execute, so every rank answers for its own run and is Modified() when any needs it.
    if (c->GetLocalProcessId() == 0)
    {
      uint64_t id = this->Internals->LiveUpdateId;
      c->TriggerRMIOnAllChildren(&id, static_cast<int>(sizeof(id)), nvi::kLiveUpdateRmiTag);
    }
    return this->NeedsUpdateOnEveryRank(c, this->LocalNeedsUpdate());
  }
  if (this->LocalNeedsUpdate())
  {
    this->Modified();
    return true;
  }
  return false;
}

bool vtkNeuralCompress::LocalNeedsUpdate()
{
  vtkInternals& in = *this->Internals;
  // A preparation: it ended (its job starts at the next update), its stage changed or a second passed (the panel's
  // status line says what it does and for how long).
  const auto now = std::chrono::steady_clock::now();
  const bool preparing = in.Preparing && !in.Preparing->Adopted &&
    (in.Preparing->Serial() != in.PreparingSerialShown || now - in.PreparingShownAt >= std::chrono::seconds(1));
  // A run: its status changed, or (while it trains) a live snapshot's bytes were written since the last update.
  nvi::Job* job = in.Current.get();
  const nvi::RunStatus status = job && job->Run ? job->Run->status() : nvi::RunStatus();
  if (preparing ||
    (job && job->Run &&
      (status.Serial != job->EmittedSerial || (!nvi::isSettled(status.State) && job->LiveBytesPending()))))
  {
    if (in.Preparing)
    {
      in.PreparingSerialShown = in.Preparing->Serial();
      in.PreparingShownAt = now;
    }
    return true;
  }
  return false;
}

nvi::TrainingRun* vtkNeuralCompress::CurrentRun()
{
  vtkInternals& in = *this->Internals;
  return in.Current ? in.Current->Run.get() : nullptr;
}

void vtkNeuralCompress::ExtendTraining(int64_t steps, bool fastForward)
{
  vtkInternals& in = *this->Internals;
  if (!in.Current)
  {
    return;
  }
  nvi::Job& job = *in.Current;
  in.SummaryPrinted = false;
  if (job.Run)
  {
    job.Run->extend(steps, fastForward);
  }
  else if (job.Data && job.Field.Stats.max > job.Field.Stats.min)
  {
    // A cached or restored network: one run that trains `steps` more from it, its step count going on.
    std::shared_ptr<const nvi::NetworkRecord> final = job.Final();
    const nv::RunLimits limits = nvi::ContinuedRunLimits(job.TrainingSettings, final ? final->Figures.Steps : 0);
    this->StartRun(job, limits, steps, fastForward);
  }
  this->Modified();
}

void vtkNeuralCompress::SetTrainingSteps(int steps)
{
  if (steps < 0)
  {
    vtkWarningMacro("Neural Compress: Training Steps " << steps << " is negative: set to 0 (no training; the network "
                                                       "stays its initialisation). Set a positive number of steps.");
    steps = 0;
  }
  if (steps != this->TrainingSteps)
  {
    this->TrainingSteps = steps;
    this->Modified();
  }
}

void vtkNeuralCompress::SetMaxError(double bound)
{
  if (!(std::isfinite(bound) && bound >= 0.0))
  {
    vtkWarningMacro("Neural Compress: Max Error " << bound << " is refused: the bound is a finite number >= 0 in the "
                                                     "data's units (0 = off). The error-bounded mode is off.");
    bound = 0.0;
  }
  if (bound != this->MaxError)
  {
    this->MaxError = bound;
    this->Modified();
  }
}

void vtkNeuralCompress::PauseTraining()
{
  if (nvi::TrainingRun* run = this->CurrentRun())
  {
    run->pause();
    this->Modified();
  }
}

void vtkNeuralCompress::ResumeTraining()
{
  if (nvi::TrainingRun* run = this->CurrentRun())
  {
    run->resume();
    this->Modified();
  }
}

void vtkNeuralCompress::ContinueTraining()
{
  this->ExtendTraining(this->ContinueSteps, false);
}

void vtkNeuralCompress::FastForward()
{
  this->ExtendTraining(1000, true);
}

void vtkNeuralCompress::StopTraining()
{
  vtkInternals& in = *this->Internals;
  if (nvi::TrainingRun* run = this->CurrentRun())
  {
    run->stop();
    this->Modified();
  }
  else if (in.Preparing && !in.Preparing->Adopted)
  {
    in.StopBeforeStart = true; // kept for the job that the preparation starts (a Stop is never lost)
    this->Modified();
  }
}

void vtkNeuralCompress::DecodeNow()
{
  this->Internals->DecodeRequested = true;
  this->Modified();
}

void vtkNeuralCompress::MeasureNow()
{
  this->Internals->MeasureRequested = true;
  this->Modified();
}

void vtkNeuralCompress::WaitForTraining(double seconds)
{
  vtkInternals& in = *this->Internals;
  const auto start = std::chrono::steady_clock::now();
  if (in.Preparing && !in.Preparing->Adopted)
  {
    // The field is being prepared: its job starts here when it is ready (or its error is printed).
    if (seconds < 0.0)
    {
      in.Preparing->Wait();
    }
    else if (!in.Preparing->WaitFor(seconds))
    {
      return; // still preparing after `seconds`
    }
    this->AdoptPreparation();
    this->Modified();
  }
  if (nvi::TrainingRun* run = this->CurrentRun())
  {
    const double spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    run->wait(seconds < 0.0 ? seconds : std::max(0.0, seconds - spent));
    this->Modified();
  }
}

const char* vtkNeuralCompress::GetTrainingStatus()
{
  return this->Internals->StatusText.c_str();
}

vtkIdType vtkNeuralCompress::GetTotalStepsTrained()
{
  vtkInternals& in = *this->Internals;
  vtkIdType steps = in.StepsOfEndedJobs;
  if (in.Current && in.Current->Run)
    steps += in.Current->Run->status().Steps;
  return steps;
}

void vtkNeuralCompress::SetTrainedNetworks(const char* value)
{
  vtkInternals& in = *this->Internals;
  const std::string text = value ? value : "";
  if (text == in.TrainedNetworksSet)
  {
    return;
  }
  in.TrainedNetworksSet = text;
  std::string error;
  if (!text.empty() && this->Device != DEVICE_CPU)
  {
    // A state brings networks back: their sessions will be made once the input has updated; the CUDA context is
    // made meanwhile.
    vtkNeuralCudaDevice::CreateContextInBackground();
  }
  std::map<uint64_t, std::vector<uint8_t>> networks = nvi::DecodeNetworks(text, error);
  if (!error.empty())
  {
    vtkWarningMacro("Neural Compress: TrainedNetworks: " << error << "; those networks are trained again.");
  }
  for (auto& n : networks)
  {
    try
    {
      in.Restored[n.first] = nvi::ShareBytes(n.second);
    }
    catch (const std::exception& e)
    {
      vtkWarningMacro("Neural Compress: TrainedNetworks: a network of the state cannot be used ("
        << e.what() << "); it is trained again.");
    }
  }
}

const char* vtkNeuralCompress::GetTrainedNetworks()
{
  vtkInternals& in = *this->Internals;
  std::vector<const nvi::NetworkRecord*> records;
  for (const nvi::NetworkRecord* r : in.Cache.All())
  {
    if (r->Figures.State != "Interrupted")
      records.push_back(r);
  }
  in.TrainedNetworksText = nvi::EncodeNetworks(records) + in.PeerNetworksText; // MPI: the other ranks' too
  return in.TrainedNetworksText.c_str();
}

int vtkNeuralCompress::GetGpuUsable()
{
  return nv::cudaAvailable() ? 1 : 0;
}
