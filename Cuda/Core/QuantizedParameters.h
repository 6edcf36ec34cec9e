// NeuralVolume engine: the stored parameters of a Precision::Quantized8 model (serialization format version 4).
//
// Block layout (little endian), for the levels of the model's grid layout in order:
//   f32 step                 the level's quantisation step (GridQuantizer::validStep)
//   RansCoder block          the level's entries x features codes as symbols 0..254 (GridQuantizer::symbol), in
//                            parameter order
// then the MLP weights as fp16 (Model::mlpParamCount() x u16). Model::parameterBytes() of a Quantized8 model is the
// size of this block.
#pragma once

#include "Model.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace nv
{

/// The block of a model quantised by Model::quantize(Precision::Quantized8) (its levelSteps() and parameters; a
/// parameter off its level's grid is stored as the code it rounds to).
std::vector<uint8_t> encodeQuantizedParameters(const Model& model);

/// Checks the block of a model of `config` at data[0..size) without decoding or allocating: every step, every coder
/// table and stream length against the bytes present. Returns the block's bytes (at most `size`).
size_t inspectQuantizedParameters(const uint8_t* data, size_t size, const ModelConfig& config);

/// Decodes a block that inspectQuantizedParameters() accepted into `model` (of the same configuration): its
/// parameters, level steps and storage precision (Quantized8). Throws nv::Error on a corrupt stream.
void decodeQuantizedParameters(const uint8_t* data, size_t size, Model& model);

} // namespace nv
