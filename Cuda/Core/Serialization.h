// NeuralVolume engine: versioned binary format of a model.
//
// Layout (little endian): magic "NVOLNET\0", u32 version, u32 header bytes, header fields (config, storage
// precision, source info, training stats), u64 parameter count, parameters (fp32 or fp16), [version 2: the domain
// mask -- u64 run count, then u32 run lengths over the source samples (x fastest), alternately outside and inside,
// starting with outside], [version 3: u32 flags (1: a domain mask follows as in version 2, 2: an occupancy mask
// follows -- u64 run count, u32 run lengths over the macrocells, alternately empty and occupied, then f64 background)],
// u32 CRC-32 of everything before it. Models without a domain mask are written as version 1 (byte for byte as
// before), with one only as version 2, with an occupancy mask as version 3; all are read. Version 4 holds a
// Quantized8 model (and only such): after the parameter count, u64 block bytes and the block of
// QuantizedParameters.h (per level a step and an entropy-coded stream of 8-bit codes, then the MLP as fp16) in place
// of the parameters, then u32 mask flags (0 to 3, as in version 3) and the masks they name. Version 5 holds a model in
// the error-bounded mode (ErrorCorrections.h), of any precision: the parameters as their precision's version has them
// (Quantized8: u64 block bytes and the block), u32 mask flags and the masks, then f64 bound (source units, > 0),
// u64 correction count, u64 coded bytes and the coded list. Reading checks magic,
// version, the checksum, then every field against the bytes present and the bounds of Model.h (source grids of at
// most 2^20 samples per axis and 2^34 in all, finite geometry, positive spacing) before it allocates anything.
#pragma once

#include "Model.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nv
{

constexpr uint32_t kFormatVersion = 5;     ///< the newest version this build reads and writes
constexpr uint32_t kFormatVersionCorrections = 5; ///< written for models in the error-bounded mode (any precision)
constexpr uint32_t kFormatVersionQuantized = 4; ///< written for Quantized8 models (with or without masks)
constexpr uint32_t kFormatVersionOccupancy = 3; ///< written for fp32/fp16 models with an occupancy mask
constexpr uint32_t kFormatVersionDomain = 2; ///< written for models with a domain mask only
constexpr uint32_t kFormatVersionNoMask = 1; ///< written for models without a domain mask

/// What a model's bytes hold, every field checked against the bytes present and the bounds of Model.h (configuration,
/// source grid: validate(SourceInfo), parameter count, mask runs) without allocating more than the two strings of the
/// header (at most 4 KiB each). deserialize() inspects first, then allocates exactly `hostBytes`.
struct ModelFileInfo
{
  uint32_t version = 0;
  ModelConfig config;
  Precision precision = Precision::Float32;
  SourceInfo source; ///< without its masks (see hasDomain, hasOccupancy)
  TrainingStats stats;
  uint64_t parameterCount = 0;
  bool hasDomain = false;
  bool hasOccupancy = false;
  /// Host bytes of the model deserialize() builds: 4 per parameter (fp16: at most twice the file's parameter bytes;
  /// Quantized8: at most 4 x 1024 times its coded streams' bytes, RansCoder::kMaxSymbolsPerByte) and the masks' bits
  /// (a domain mask at most 512 MiB: kMaxDomainSamples; an occupancy mask at most 2^34 / 8 bits). A Quantized8
  /// model's level steps (at most 32 floats) are not counted.
  uint64_t hostBytes = 0;
  size_t parametersAt = 0;    ///< offset of the stored parameters (Quantized8: of the coded block)
  size_t parameterBytes = 0;  ///< bytes of the stored parameters (Quantized8: of the coded block)
  size_t domainRunsAt = 0;    ///< offset of the domain mask's first run length
  uint64_t domainRuns = 0;
  size_t occupancyRunsAt = 0; ///< offset of the occupancy mask's first run length
  uint64_t occupancyRuns = 0;
  double correctionBound = 0.0;  ///< version 5: the error bound (source units); 0 otherwise
  uint64_t correctionCount = 0;  ///< version 5: corrections listed
  size_t correctionsAt = 0;      ///< version 5: offset of the coded list
  size_t correctionBytes = 0;    ///< version 5: bytes of the coded list
};

/// Bound on the bytes of a serialized header (244 bytes of fixed fields and two strings of at most 4096 bytes each).
constexpr uint32_t kMaxHeaderBytes = 16384;

std::vector<uint8_t> serialize(const Model& model);
/// Throws nv::Error with a clear message on truncated, corrupt, out-of-bounds or wrong-version input.
ModelFileInfo inspectModel(const uint8_t* data, size_t size);
/// inspectModel(), then the model. Throws nv::Error with a clear message on truncated, corrupt, out-of-bounds or
/// wrong-version input, always before allocating the parameters or masks.
Model deserialize(const uint8_t* data, size_t size);
inline Model deserialize(const std::vector<uint8_t>& bytes) { return deserialize(bytes.data(), bytes.size()); }

void saveModel(const Model& model, const std::string& path);
Model loadModel(const std::string& path);

uint32_t crc32(const uint8_t* data, size_t size);

} // namespace nv
