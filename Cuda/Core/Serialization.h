// NeuralVolume engine: versioned binary format of a model.
//
// Layout (little endian): magic "NVOLNET\0", u32 version, u32 header bytes, header fields (config, storage
// precision, source info, training stats), u64 parameter count, parameters (fp32 or fp16), [version 2: the domain
// mask -- u64 run count, then u32 run lengths over the source samples (x fastest), alternately outside and inside,
// starting with outside], [version 3: u32 flags (1: a domain mask follows as in version 2, 2: an occupancy mask
// follows -- u64 run count, u32 run lengths over the macrocells, alternately empty and occupied, then f64 background)],
// u32 CRC-32 of everything before it. Models without a domain mask are written as version 1 (byte for byte as
// before), with one only as version 2, with an occupancy mask as version 3; all are read. Reading checks magic,
// version, sizes, ranges and the checksum.
#pragma once

#include "Model.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nv
{

constexpr uint32_t kFormatVersion = 3;     ///< the newest version this build reads and writes
constexpr uint32_t kFormatVersionDomain = 2; ///< written for models with a domain mask only
constexpr uint32_t kFormatVersionNoMask = 1; ///< written for models without a domain mask

std::vector<uint8_t> serialize(const Model& model);
/// Throws nv::Error with a clear message on truncated, corrupt or wrong-version input.
Model deserialize(const uint8_t* data, size_t size);
inline Model deserialize(const std::vector<uint8_t>& bytes) { return deserialize(bytes.data(), bytes.size()); }

void saveModel(const Model& model, const std::string& path);
Model loadModel(const std::string& path);

uint32_t crc32(const uint8_t* data, size_t size);

} // namespace nv
