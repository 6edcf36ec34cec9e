// NeuralVolume engine: the error-bounded mode's sparse corrections (VTK-free).
//
// After training, the source samples whose decoded value misses the source by more than kCorrectAbove x bound are
// listed with a correction in steps of the bound: value + steps x bound lies within bound / 2 of the source on the
// decode that computed them. The others were within kCorrectAbove x bound there; the margin left (1 - kCorrectAbove
// of the bound) covers another decode's rounding (the other device's, fp16 accumulation), so every voxel of a decode on
// the source's grid meets the bound. Stored form (model format version 5, Serialization.h): two byte streams, each as
// u64 byte count and its rANS block (RansCoder.h; none for 0 bytes): the unsigned LEB128 varints of every correction's
// index step from the previous one (the first from -1), then the zig-zag varints of their steps.
#pragma once

#include "Volume.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace nv
{

/// Samples within this fraction of the bound on the decode that computes the corrections are left as they are.
constexpr double kCorrectAbove = 0.9;

struct ErrorCorrections
{
  /// The bound on |decoded - source| in source units; 0: the mode is off (then no corrections).
  double bound = 0.0;
  std::vector<int64_t> index; ///< source samples (x fastest), strictly ascending
  std::vector<int32_t> steps; ///< per sample: the correction in units of the bound (never 0)

  bool enabled() const { return bound > 0.0; }
  int64_t count() const { return static_cast<int64_t>(index.size()); }
  /// Bytes of the coded list (encodeCorrections(): codes the list, O(count)).
  int64_t codedBytes() const;
  /// Bytes the mode adds to a stored model: the bound, the count, the coded size and the list (0 when off).
  int64_t storedBytes() const;
};

/// Throws nv::Error unless `bound` is a usable bound in source units: finite and >= 0 (0: off).
void validateErrorBound(double bound);

/// The corrections that bring `decoded` (the network's values at every sample of `source`, source units, x fastest)
/// within `bound` of the source; non-finite source samples are skipped. Throws nv::Error for a bound that is not
/// finite or not > 0, a decoded value that is not finite where the source is, or a correction beyond 2^31 - 1 steps
/// (a bound too small for the network's error).
ErrorCorrections computeCorrections(const double* decoded, const VolumeView& source, double bound);
/// The same for the samples [first, first + count) of `source` (decoded[k]: sample first + k), appended to
/// `corrections` (its bound set, > 0): slab by slab, in ascending order of `first`.
void appendCorrections(ErrorCorrections& corrections, const double* decoded, const VolumeView& source, int64_t first,
  int64_t count);

/// Applies the corrections of the samples [first, first + count) of the source grid to `values` (value of sample
/// first + k at values[k], source units).
void applyCorrections(const ErrorCorrections& corrections, int64_t first, int64_t count, float* values);
void applyCorrections(const ErrorCorrections& corrections, int64_t first, int64_t count, double* values);
/// The same on normalised values (v - valueMin) / (valueMax - valueMin): the renderers' decoded grids.
void applyCorrectionsNormalised(const ErrorCorrections& corrections, int64_t first, int64_t count, double valueMin,
  double valueMax, float* values);

std::vector<uint8_t> encodeCorrections(const ErrorCorrections& corrections);
/// The coded list of two varint streams as they are (tests craft hostile lists with it).
std::vector<uint8_t> packCorrectionStreams(const std::vector<uint8_t>& indexVarints, const std::vector<uint8_t>& stepVarints);
/// Checks `bytes` bytes of a coded list of `count` corrections over a grid of `samples` samples: both streams' sizes
/// (at most 10 and 5 bytes a correction) and rANS blocks against the bytes present before decoding them (at most
/// RansCoder::kMaxSymbolsPerByte symbols a coded byte), every varint complete, indices strictly ascending and below
/// `samples`, steps non-zero and within 32 bits, all the bytes used. Throws nv::Error naming what is wrong.
void inspectCorrections(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples);
/// inspectCorrections(), then the list (its bound set to `bound`).
ErrorCorrections decodeCorrections(const uint8_t* data, size_t bytes, uint64_t count, int64_t samples, double bound);

} // namespace nv
