// NeuralVolume engine: a trained (or untrained) neural representation of one scalar field.
#pragma once

#include "Config.h"
#include "ErrorCorrections.h"
#include "HashGridMath.h"
#include "ValueRange.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nv
{

/// Where the field came from: enough to place the decoded grid and to de-normalise its values.
struct SourceInfo
{
  int64_t dims[3] = { 1, 1, 1 };       ///< number of samples per axis of the source grid
  double origin[3] = { 0, 0, 0 };
  double spacing[3] = { 1, 1, 1 };
  double bounds[6] = { 0, 0, 0, 0, 0, 0 }; ///< xmin xmax ymin ymax zmin zmax: maps to [0,1]^3
  double valueMin = 0.0;               ///< normalised 0 <-> valueMin
  double valueMax = 1.0;               ///< normalised 1 <-> valueMax
  std::string arrayName;
  int association = 0;                 ///< 0 = point data, 1 = cell data
  int64_t rawBytes = 0;                ///< bytes of the source array (for the compression ratio)
  /// The source's domain inside the box (inputs resampled onto an image): one bit per source sample, x fastest,
  /// 1 = inside. Empty: the whole box. Renderers draw nothing where the nearest source sample is outside.
  std::vector<uint32_t> domain;
  /// A sparse source (an OpenVDB grid's active voxels): one bit per macrocell (macrocellLayout(dims), x fastest),
  /// 1 = the cell's interpolated field may differ from `background`. Empty: every cell. In a cell without the bit the
  /// field is `background` exactly: renderers use that value there (and skip the cell where it is transparent).
  std::vector<uint32_t> occupancy;
  double background = 0.0; ///< source units; used with `occupancy`
};

/// Bounds of a source grid that a model may state (its file's reader refuses larger ones before allocating): at
/// most 2^20 samples per axis and 2^34 in all (2048^3 is 2^33; 4096^3 is refused). Within them no product of
/// dims, macrocells or mask bits overflows 64 bits, and a mask's bits stay below 2^34.
constexpr int64_t kMaxSourceAxisSamples = int64_t(1) << 20;
constexpr int64_t kMaxSourceSamples = int64_t(1) << 34;
/// A domain mask (one bit per source sample) covers fewer than 2^32 samples: at most 512 MiB of bits.
constexpr int64_t kMaxDomainSamples = (int64_t(1) << 32) - 1;

/// Number of 32-bit words of an occupancy mask for a source of `dims` samples (its macrocells).
int64_t occupancyWords(const int64_t dims[3]);
/// Number of 32-bit words of a domain mask for a source of `dims` samples.
int64_t domainWords(const int64_t dims[3]);

/// Throws nv::Error unless `source` is a grid a model may state: every dimension in 1..kMaxSourceAxisSamples and
/// their product at most kMaxSourceSamples (checked without overflow), finite origin, positive finite spacing,
/// finite bounds with min <= max per axis, a finite value range with max >= min, association 0 or 1,
/// non-negative raw bytes, and masks (when present) of the size their dims need (a domain mask over at most
/// kMaxDomainSamples samples).
void validate(const SourceInfo& source);

/// Whether the normalised point u (in [0,1]^3) lies in the domain of `src` (always true without a domain mask).
bool inDomain(const SourceInfo& src, const float u[3]);

struct TrainingStats
{
  int64_t steps = 0;
  double seconds = 0.0;
  double finalLoss = 0.0;
  double psnr = 0.0;        ///< dB, over all source samples, values normalised by the source range
  double maxError = 0.0;    ///< max |decoded - source| in source units
  int64_t invalidSamples = 0; ///< NaN/Inf source samples excluded from training
  std::string device;
};

/// How a model's parameters are stored (serialized, and so decoded: Model::quantize()).
enum class Precision : int
{
  Float32 = 0,
  Float16 = 1,
  /// Hash-table entries as 8-bit codes with one step per level, entropy coded (GridQuantizer.h, RansCoder.h); MLP
  /// weights fp16. Format version 4 (Serialization.h).
  Quantized8 = 2
};

/// A precision's short name: "fp32", "fp16" or "q8".
const char* precisionName(Precision p);

/// Layout of the parameter vector: hash table (entries x features), then MLP layers (row-major [out][in]).
class Model
{
public:
  Model() = default;
  explicit Model(const ModelConfig& config);

  const ModelConfig& config() const { return Config; }
  const GridLayout& layout() const { return Layout; }

  size_t encodingParamCount() const { return static_cast<size_t>(Layout.totalEntries) * Layout.features; }
  size_t mlpParamCount() const;
  size_t paramCount() const { return Params.size(); }
  /// Offset of MLP layer `l` (0 = first hidden layer, hiddenLayers = output layer) in the parameter vector.
  size_t layerOffset(int l) const;
  int layerInputs(int l) const;
  int layerOutputs(int l) const;

  std::vector<float>& params() { return Params; }
  const std::vector<float>& params() const { return Params; }

  /// Hash table U(-1e-4, 1e-4); MLP U(-1/sqrt(fan_in), 1/sqrt(fan_in)) (PyTorch's nn.Linear default).
  void initialize(uint64_t seed);

  /// Round every parameter to the storage precision (so the model decodes exactly as it will be stored).
  /// Quantized8: each level's entries to its step's grid (a level already on the grid of its step in levelSteps()
  /// keeps that step, so quantising again changes nothing), the MLP to fp16; the coded size is computed once here.
  void quantize(Precision p);
  /// Record the storage precision of parameters that already hold such values (a deserialized fp16 network):
  /// quantize() without its rounding pass. Not for Quantized8 (see setQuantizedState()).
  void setStoragePrecision(Precision p);
  /// Record a deserialized Quantized8 network: its per-level steps and the bytes of its coded parameters.
  void setQuantizedState(std::vector<float> levelSteps, int64_t codedBytes);
  Precision storagePrecision() const { return Storage; }
  /// Quantized8: the quantisation step of each hash-grid level (empty otherwise).
  const std::vector<float>& levelSteps() const { return LevelSteps; }
  /// Bytes the parameters take in the serialized form (Quantized8: the coded block, as of the last quantize()).
  int64_t parameterBytes() const;
  /// Quantized8: the coded block (QuantizedParameters.h) the last quantize() computed, while the parameters and
  /// steps are still those it was computed from (a fingerprint of them is compared: one pass, no coding); null
  /// otherwise. serialize() writes it instead of coding the parameters again.
  const std::vector<uint8_t>* codedParameters() const;

  SourceInfo source;
  TrainingStats stats;
  /// The error-bounded mode (ErrorCorrections.h): the bound and the corrections of the stored parameters, applied by
  /// decodeGridValues() on the source's grid. Off (bound 0) unless set after training; changing the parameters
  /// makes them stale (the filter computes them again at each phase end).
  ErrorCorrections corrections;
  /// Bytes of the stored network: parameterBytes() and the corrections' (ErrorCorrections::storedBytes()). The
  /// compression ratio is source.rawBytes / storedBytes().
  int64_t storedBytes() const { return parameterBytes() + corrections.storedBytes(); }

  /// Map a de-normalised value to [0,1] and back.
  double denormalize(double y) const { return valueRange().denormalize(y); }
  /// The source value range as a normalisation map (ValueRange.h: safe when max - min overflows).
  ValueRange valueRange() const { return ValueRange(source.valueMin, source.valueMax); }

private:
  ModelConfig Config;
  GridLayout Layout{};
  std::vector<float> Params;
  Precision Storage = Precision::Float32;
  std::vector<float> LevelSteps; ///< Quantized8 only
  int64_t CodedBytes = 0;        ///< Quantized8 only
  std::shared_ptr<const std::vector<uint8_t>> CodedBlock; ///< Quantized8 only: see codedParameters()
  uint64_t CodedFingerprint = 0;
  uint64_t fingerprint() const;
  void clearQuantizedState();
};

/// MLP weights of a network of this configuration (no biases): inputs x width, width x width per further hidden
/// layer, width x 1.
size_t mlpParameterCount(const ModelConfig& config);

/// Level table for an encoding configuration (validates it).
GridLayout makeGridLayout(const EncodingConfig& config);

/// Choose the largest log2 table size (in [minLog2, maxLog2]) whose model keeps raw/model >= targetRatio.
/// Quantized8 counts 1 byte per table feature and 2 per MLP weight: the size of uniformly spread codes (trained tables
/// code to about 6.5 to 7 bits a feature, so the ratio reported after training is higher; see Model::parameterBytes()).
int chooseLog2TableSize(ModelConfig config, int64_t rawBytes, double targetRatio, Precision storage,
  int minLog2 = 10, int maxLog2 = 24);

/// Raw bytes / stored bytes of a network of `config` (its table size as set) stored in `storage`, counted as
/// chooseLog2TableSize() counts it (Quantized8: a byte per table feature).
double estimatedRatio(const ModelConfig& config, int64_t rawBytes, Precision storage);

/// The automatic size of Neural Compress (Log2TableSize 0, issue 25): the table and the storage.
struct AutomaticSize
{
  int log2TableSize = 10;
  Precision storage = Precision::Float16;
  bool targetReached = false; ///< the estimated ratio reaches the target (false: a small input, sized for quality)
};
/// Where the target ratio is reachable: the largest table that reaches it in `storage` (automaticStorage: in 8-bit
/// codes, which at equal bytes hold a table twice as large; at 500 steps on the CPU walnut at 10:1 goes from 2^10
/// fp16, 29.5 dB at 17.1:1, to 2^11 q8, 31.6 dB at 18.6:1, stent from 2^12 fp16, 34.7 dB at 15.1:1, to 2^13 q8,
/// 35.6 dB at 17.9:1). Where no table reaches it (a small input) and the target was not set (`targetIsDefault`), the
/// quality-first size: the largest table that still compresses the field (estimated ratio >= 1), else the smallest
/// (headsq 64 x 64 x 93 int16: 2^13 q8, 35.4 dB at 1.7:1, where 2^10 fp16 gave 31.3 dB at 4.6:1). An explicit target
/// out of reach keeps the smallest table (the caller warns).
AutomaticSize chooseAutomaticSize(const ModelConfig& config, int64_t rawBytes, double targetRatio,
  bool targetIsDefault, bool automaticStorage, Precision storage);

/// IEEE half conversion (round to nearest even), used for fp16 storage.
uint16_t floatToHalf(float f);
float halfToFloat(uint16_t h);

} // namespace nv
