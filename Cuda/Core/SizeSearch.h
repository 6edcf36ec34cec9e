// NeuralVolume engine: the smallest network that reaches a PSNR (Neural Compress's SizeForPSNR, issue 25).
//
// The automatic size of Neural Compress aims at a compression ratio (chooseAutomaticSize). A user who needs a quality
// instead asks for a PSNR: the hash-table size is searched by training. Each candidate network is trained from the
// same seed for the same steps, stored in its precision (8-bit codes, fp16, fp32) and measured over every voxel; the
// table sizes are bisected on the assumption that the PSNR grows with the table. It does, except where it levels off
// at the largest sizes (a 48^3 Wavelet at 300 CPU steps, 8-bit: 2^12 35.44 dB, 2^13 36.53, 2^14 38.34, 2^15 37.61), so
// the two largest candidates are trained first: when both miss the target, the search ends there, keeps the better and
// says so. Between neighbouring sizes in the middle the PSNR may still wiggle by a few tenths of a dB: the size found
// is the smallest that reaches the target on the bisection's path, and the final network's own PSNR is what counts.
//   nv::SizeSearchResult r = nv::searchSizeForPsnr(request, abort);
//   config.encoding.log2TableSize = r.log2TableSize;   // r.reached: whether any candidate reached the target
#pragma once

#include "Config.h"
#include "Model.h"
#include "NetworkSession.h"
#include "Volume.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace nv
{

/// One trained candidate.
struct SizeTrial
{
  int log2TableSize = 0;
  double psnr = 0.0;       ///< of the stored network over every valid voxel (dB; NaN for a diverged network)
  int64_t storedBytes = 0; ///< Model::storedBytes() of the stored network
};

struct SizeSearchRequest
{
  Device device = Device::Cpu;     ///< resolved (Cpu or Cuda)
  SessionOptions session;          ///< of the sessions the candidates train in
  VolumeView field;                ///< the training field (dense)
  SourceInfo source;               ///< what the network represents (range, raw bytes)
  ModelConfig config;              ///< the layout; its log2TableSize is searched
  TrainConfig train;               ///< the optimiser (its annealed schedule planned over `steps`)
  int64_t steps = 0;               ///< steps each candidate trains (> 0)
  double targetPsnr = 0.0;         ///< dB (> 0)
  Precision storage = Precision::Quantized8; ///< the precision each candidate is stored and measured in
  int minLog2 = 10, maxLog2 = 10;  ///< the table sizes searched (inclusive)
};

struct SizeSearchResult
{
  int log2TableSize = 0;         ///< the smallest table that reached the target, else the better of the two largest
  bool reached = false;          ///< a candidate reached the target
  std::vector<SizeTrial> trials; ///< in the order trained
  double seconds = 0.0;          ///< the search's wall time
  /// "sized for PSNR 40 dB: 2^13 q8, the smallest of 2^10..2^17 to reach it in 500 steps (trained in 12.5 s: 2^17
  /// 45.1 dB, 2^13 40.3 dB, 2^11 35.2 dB, 2^12 38.1 dB)", or "...: 2^17 q8, the better of the two largest that
  /// compress, did not reach it in 500 steps (trained in 3.1 s: 2^17 38.2 dB, 2^16 38.0 dB)".
  std::string describe(const SizeSearchRequest& request) const;
};

/// Trains the candidates (see the file comment). `abort` (may be null) is polled between chunks of steps: an abort
/// throws nv::Error. Throws nv::Error for an invalid request (no field, steps or target, an empty range).
SizeSearchResult searchSizeForPsnr(const SizeSearchRequest& request, const std::function<bool()>& abort);

/// The stored network's PSNR of one candidate: `config` at `log2TableSize`, trained `steps` steps from the request's
/// seed, stored in the request's precision and compared with the field over every valid voxel.
SizeTrial trainSizeCandidate(const SizeSearchRequest& request, int log2TableSize, const std::function<bool()>& abort);

} // namespace nv
