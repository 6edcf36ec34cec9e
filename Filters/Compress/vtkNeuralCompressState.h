// Private to NeuralVolume::Filters: the state vtkNeuralCompress keeps between executions (shared by its source files).
#ifndef vtkNeuralCompressState_h
#define vtkNeuralCompressState_h

#include "vtkNeuralCompress.h"
#include "vtkNeuralCompressDataSetPiece.h"
#include "vtkNeuralCompressDistributed.h"
#include "vtkNeuralCompressParticlePiece.h"
#include "vtkNeuralCompressGlobalFigures.h"
#include "vtkNeuralCompressPartition.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressNetworkCache.h"
#include "vtkNeuralCompressPreparation.h"
#include "vtkNeuralCompressResample.h"
#include "vtkNeuralCompressSurroundings.h"

#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace nvi = vtkNeuralCompressInternals;

/// The filter's particle properties (particle inputs; ignored by the others).
nvi::ParticleSettings ParticleSettingsOf(vtkNeuralCompress* filter);

//------------------------------------------------------------------------------
struct vtkNeuralCompress::vtkInternals
{
  std::unique_ptr<nvi::Job> Current;
  std::shared_ptr<nv::NetworkSession> Session; ///< reused by every job while the device and threads stay
  int SessionDevice = -1;
  int SessionThreads = -1;
  int SessionCudaDevice = -1; ///< the GPU ordinal it was made for (vtkNeuralCudaDevice.h)
  uint64_t LiveUpdateId = 0;  ///< MPI: this filter's number in the live-update RMI's list (vtkNeuralCompressPiece.cxx)
  nvi::NetworkCache Cache;
  nvi::InputResampler Resampler; ///< inputs that are not images, resampled onto one
  int AnnouncedDims[3] = { 0, 0, 0 }; ///< sampling dimensions announced by RequestInformation (0: none)
  nvi::DistributedInput Distributed; ///< MPI: the input gathered to rank 0 (vtkNeuralCompressDistributed.h)
  nvi::ImagePiece Piece; ///< MPI, image input: this rank's piece (vtkNeuralCompressPartition.h)
  /// MPI, dataset or composite: this rank's resampled piece (vtkNeuralCompressDataSetPiece.h)
  nvi::DataSetPiece GridPiece;
  bool GridPieceActive = false; ///< while Execute trains GridPiece's image (its array and domain mask are used)
  // MPI, dataset or composite: RequestInformation's decision (AnnounceGridPieces), renewed when this stamp changes.
  uint64_t GridDecisionStamp = 0;
  bool GridDecided = false;
  bool GridPieces = false; ///< every rank trains its own piece (RequestData's branch)
  int GridDims[3] = { 0, 0, 0 }; ///< the whole lattice announced (0: none)
  nvi::ParticlePiece Particles; ///< MPI, particle set: this rank's reconstruction (vtkNeuralCompressParticlePiece.h)
  bool ParticlePieces = false;  ///< GridPieces of a particle set: Particles rather than GridPiece
  /// The domain mask and description of the resampled piece GridPieceActive trains.
  std::shared_ptr<std::vector<uint8_t>> PieceOutside() const
  {
    return this->ParticlePieces ? this->Particles.Outside() : this->GridPiece.Outside();
  }
  const std::string& PieceDescription() const
  {
    return this->ParticlePieces ? this->Particles.Description() : this->GridPiece.Description();
  }
  /// The network MeasuredSums measured (its final record). Weak: a record freed since cannot pass for a new one that
  /// the allocator placed at its address (a time series' next step once showed the first step's figures that way).
  std::weak_ptr<const nvi::NetworkRecord> MeasuredRecord;
  nvi::PieceSums MeasuredSums;
  std::string PeerNetworksText; ///< rank 0 under MPI: the other ranks' networks (";key:base64" entries)
  uint64_t GatheredSignature = 0; ///< this rank's networks at the last GatherPeerNetworks
  /// MPI, one network per rank: the coarse grid of the whole field (vtkNeuralCompressSurroundings.h)
  nvi::Surroundings Surroundings;
  std::map<uint64_t, nvi::NetworkBytes> Restored; ///< networks of a loaded state, by training key
  std::string TrainedNetworksSet;
  std::string TrainedNetworksText;
  std::string StatusText;
  bool DecodeRequested = false;
  bool MeasureRequested = false; ///< MeasureNow: the next execution measures a paused out-of-core run
  bool SummaryPrinted = false;
  bool FromCache = false; ///< the current job's network is one trained before, taken from the cache
  size_t NotesPrinted = 0;    ///< notes of the current run printed (as text)
  size_t WarningsPrinted = 0; ///< warnings of the current run printed
  vtkIdType StepsOfEndedJobs = 0;
  /// StopTraining while the field was still being prepared (no run yet): the job started from that preparation
  /// stops at once instead of training (cleared when a new preparation begins).
  bool StopBeforeStart = false;

  // The key of the last input seen (recomputed when the input, its content or the settings change).
  nvi::InputIdentity KeyIdentity;
  uint64_t Key = 0;

  /// The network stored for this input and these settings (`key`) at `time`, in `stored` (null: none): the cache's
  /// (unless a run cut short left it "Interrupted"), else one restored from a state. Returns the cache's record.
  const nvi::NetworkRecord* StoredNetwork(double time, uint64_t key, nvi::NetworkBytes& stored);
  /// The session every job shares: a new one (holding `storedModel`) when the device or threads change, else the
  /// same one, given `storedModel` when `haveStored`.
  void UseSession(nv::Device device, const nv::SessionOptions& options, const nv::Model& storedModel, bool haveStored);

  /// Ends the current job: its network goes to the cache (a run cut short by this as a warm-start seed only: its
  /// phase end keeps the network without decoding or measuring it, state "Interrupted").
  void Retire()
  {
    if (!this->Current)
      return;
    nvi::Job& job = *this->Current;
    if (job.Run)
    {
      const nvi::RunState s = job.Run->status().State;
      job.Retiring = !nvi::isSettled(s);
      job.Run->stop();
      job.Run->wait(-1.0);
      this->StepsOfEndedJobs += job.Run->status().Steps;
    }
    if (std::shared_ptr<const nvi::NetworkRecord> final = job.Final())
    {
      this->Cache.Put(*final);
    }
    this->Current.reset(); // joins the run's thread
  }

  /// The field of a new input being prepared in the background (null when none); declared last, so it ends (and
  /// joins its thread) before anything it uses.
  std::unique_ptr<nvi::Preparation> Preparing;
  uint64_t PreparingSerialShown = ~uint64_t(0); ///< the preparation's serial at the last live refresh
  std::chrono::steady_clock::time_point PreparingShownAt; ///< and when it was
};



#endif
