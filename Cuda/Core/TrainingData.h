// NeuralVolume engine: what a training run (TrainingRun.h) trains on: a single-component field (or a bank of points)
// and the PSNR probe.
#pragma once

#include "BatchSource.h"
#include "PsnrProbe.h"
#include "Volume.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nv
{

/// A single-component view of the selected array, with the copy that backs it when the array
/// could not be used in place (vectors, non-contiguous layouts, bit arrays).
struct SourceField
{
  VolumeView View;
  std::vector<unsigned char> Storage;
  int64_t RawBytes = 0;     ///< bytes of the field in the input's native type
  std::string Description;  ///< e.g. "magnitude of 3 components"
};

/// What a run trains on: the field (its storage must stay alive as long as the run) and the PSNR probe.
struct TrainingData
{
  SourceField Field;
  /// Probe sampling: a bank of training points (xyz in [0,1]^3 of the field, normalised values) that the trainer
  /// draws its batches from instead of interpolating Field; empty otherwise.
  std::vector<float> BankXyz, BankValues;
  /// Out-of-core training (OutOfCore/BlockBufferSource.h): the trainer draws every batch from this source instead of
  /// Field (whose view then carries only the dimensions, type and value range, its data null); null otherwise. The
  /// pointer keeps what the source reads (its block buffer and file) alive.
  std::shared_ptr<BatchSource> Batches;
  std::shared_ptr<void> Owner;      ///< keeps the array that Field may view in place alive
  std::unique_ptr<PsnrProbe> Probe; ///< null: no intermediate PSNR
};

} // namespace nv
