// NeuralVolume engine, out-of-core training (issue 22): figures over every sample of a volume file in one streamed
// pass of z-slabs, memory bounded by the slab size: the value range (before training: the normalisation) and the
// network's error (after training: the exact PSNR and max error, as compareDecoded gives them for a field in memory).
// `progress(fraction)` is called after each slab; returning false stops the pass (nv::Error "stopped").
#pragma once

#include "Core/Engine.h"
#include "VolumeFileReader.h"

#include <functional>

namespace nv
{
class NetworkSession;

struct FileValueRange
{
  double min = 0.0, max = 0.0; ///< of the finite samples (0, 0 when none)
  int64_t finite = 0, nonFinite = 0;
};

using FileProgress = std::function<bool(double fraction)>;

FileValueRange scanValueRange(const VolumeFileReader& reader, int64_t slabBytes, const FileProgress& progress = nullptr);

/// The session's network decoded slab by slab on the file's grid against the file's samples, normalised by
/// [valueMin, valueMax] (the network's range): compareDecoded's figures merged over the slabs.
ErrorStats measureOnFile(NetworkSession& session, const VolumeFileReader& reader, double valueMin, double valueMax,
  int64_t slabBytes, const FileProgress& progress = nullptr);

/// measureOnFile over the samples lo..hi (inclusive, per axis, indices of the reader's volume) alone: only that box is
/// read (the network is still decoded on the whole volume's grid, the planes of the box). One MPI rank's own samples.
ErrorStats measureBoxOnFile(NetworkSession& session, const VolumeFileReader& reader, const int64_t lo[3],
  const int64_t hi[3], double valueMin, double valueMax, int64_t slabBytes, const FileProgress& progress = nullptr);

} // namespace nv
