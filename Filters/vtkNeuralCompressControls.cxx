// vtkNeuralCompress: the training controls, the live-source poll and the networks saved with a state.
#include "vtkNeuralCompress.h"

#include "vtkNeuralCompressOutput.h"
#include "vtkNeuralCompressState.h"

#include "Core/Error.h"
#include "Core/Serialization.h"

#include "vtkDataArray.h"

#include <algorithm>

//------------------------------------------------------------------------------
bool vtkNeuralCompress::GetNeedsUpdate()
{
  vtkInternals& in = *this->Internals;
  if (in.Current && in.Current->Run && in.Current->Run->Status().Serial != in.Current->EmittedSerial)
  {
    this->Modified();
    return true;
  }
  return false;
}

nvi::TrainingRun* vtkNeuralCompress::CurrentRun(bool create)
{
  vtkInternals& in = *this->Internals;
  if (!in.Current)
  {
    return nullptr;
  }
  nvi::Job& job = *in.Current;
  if (!job.Run && create && job.Data && job.Field.Stats.max > job.Field.Stats.min)
  {
    // A cached or restored network: a run that starts from it (Continue, Fast-forward).
    const nv::TrainConfig& train = job.Train;
    nvi::RunLimits limits; // no steps yet: Extend() gives them
    limits.PsnrInterval = this->PSNRInterval;
    if (std::shared_ptr<const nvi::NetworkRecord> final = job.Final())
    {
      limits.FirstStep = final->M.Steps; // the step count goes on from the network's
      limits.MaxSteps = limits.FirstStep;
    }
    if (limits.PsnrInterval > 0 && !job.Data->Probe)
    {
      job.Data->Probe.reset(new nvi::PsnrProbe(job.Data->Field.View, train.seed, 65536));
    }
    nvi::Job* jobPtr = &job;
    job.Run.reset(new nvi::TrainingRun(job.Session, job.Data, train, limits,
      [jobPtr](nvi::TrainingRun&, const nvi::RunStatus& status) { jobPtr->Finalize(status); }));
    if (this->TrainInBackground)
      job.Run->StartInBackground();
    else
      job.Run->RunHere(nullptr, nullptr);
  }
  return job.Run.get();
}

void vtkNeuralCompress::PauseTraining()
{
  if (nvi::TrainingRun* run = this->CurrentRun(false))
  {
    run->Pause();
    this->Modified();
  }
}

void vtkNeuralCompress::ResumeTraining()
{
  if (nvi::TrainingRun* run = this->CurrentRun(false))
  {
    run->Resume();
    this->Modified();
  }
}

void vtkNeuralCompress::ContinueTraining()
{
  if (nvi::TrainingRun* run = this->CurrentRun(true))
  {
    this->Internals->SummaryPrinted = false;
    run->Extend(this->ContinueSteps, false);
    this->Modified();
  }
}

void vtkNeuralCompress::FastForward()
{
  if (nvi::TrainingRun* run = this->CurrentRun(true))
  {
    this->Internals->SummaryPrinted = false;
    run->Extend(1000, true);
    this->Modified();
  }
}

void vtkNeuralCompress::StopTraining()
{
  if (nvi::TrainingRun* run = this->CurrentRun(false))
  {
    run->Stop();
    this->Modified();
  }
}

void vtkNeuralCompress::DecodeNow()
{
  this->Internals->DecodeRequested = true;
  this->Modified();
}

void vtkNeuralCompress::WaitForTraining(double seconds)
{
  if (nvi::TrainingRun* run = this->CurrentRun(false))
  {
    run->Wait(seconds);
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
    steps += in.Current->Run->Status().Steps;
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
  std::map<uint64_t, std::vector<uint8_t>> networks = nvi::DecodeNetworks(text, error);
  if (!error.empty())
  {
    vtkWarningMacro("Neural Compress: TrainedNetworks: " << error << "; those networks are trained again.");
  }
  for (auto& n : networks)
  {
    in.Restored[n.first] = std::move(n.second);
  }
}

const char* vtkNeuralCompress::GetTrainedNetworks()
{
  vtkInternals& in = *this->Internals;
  std::vector<const nvi::NetworkRecord*> records;
  for (const nvi::NetworkRecord* r : in.Cache.All())
  {
    if (r->M.State != "Interrupted")
      records.push_back(r);
  }
  in.TrainedNetworksText = nvi::EncodeNetworks(records);
  return in.TrainedNetworksText.c_str();
}
