// NeuralVolume engine: the PSNR estimate a training run (TrainingRun.h) makes while it trains, on a fixed subset of
// the training targets, from the session's published network.
#pragma once

#include "NetworkSession.h"
#include "Volume.h"

#include <cstdint>
#include <vector>

namespace nv
{

/// Estimates the PSNR of a model on a fixed random subset of valid voxels.
class PsnrProbe
{
public:
  PsnrProbe(const VolumeView& view, uint64_t seed, int64_t maxSamples);
  /// On a bank of training points (xyz in [0,1]^3, normalised values; non-finite ones skipped): every
  /// max(1, count / maxSamples)-th point.
  PsnrProbe(const std::vector<float>& xyz, const std::vector<float>& values, int64_t maxSamples);
  /// Estimate from the session's current (published) network.
  double estimate(NetworkSession& session) const;
  /// Points each estimate evaluates.
  int64_t samples() const { return static_cast<int64_t>(Expected.size()); }

private:
  std::vector<float> Coords;   // xyz interleaved in [0,1]
  std::vector<float> Expected; // normalised source values
};

/// PSNR (dB) from a mean squared error of normalised values; +inf for an exact match.
double psnrFromMse(double mse);

} // namespace nv
