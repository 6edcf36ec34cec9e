#include "vtkNeuralOutOfCoreInput.h"

#include "vtkNeuralCompressGlobalFigures.h"
#include "vtkNeuralCompressJob.h"
#include "vtkNeuralCompressSettings.h"

#include "Core/Error.h"
#include "Core/HashGridMath.h"
#include "Core/NetworkSession.h"
#include "Core/PsnrProbe.h"
#include "Core/ResourceEstimate.h"
#include "Core/ValueRange.h"
#include "OutOfCore/BlockBufferSource.h"
#include "OutOfCore/FileMeasure.h"
#include "OutOfCore/VolumeBoxSource.h"

#include "vtkFieldData.h"
#include "vtkLogger.h"
#include "vtkNew.h"
#include "vtkImageData.h"
#include "vtkStringArray.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>
#include <vector>

namespace vtkNeuralCompressInternals
{
namespace
{
/// The budget's shares: the block buffer, the PSNR probe, a streamed pass's slabs (FileMeasure.cpp: the exact pass
/// holds two slabs of doubles and one of floats, 20 bytes a sample), a chunked dataset's decoded chunks.
constexpr int64_t kBufferEighths = 5, kProbeEighths = 1, kSlabEighths = 1, kChunkEighths = 1;
constexpr int64_t kProbeSamples = 65536;
constexpr int kMinBlocksPerStep = 16;
constexpr int64_t kRowReadsPerStep = 32768;
constexpr double kBlocksPerBatchSample = 1.0;
constexpr int kBrickCellsX = 64, kGpuBrickCellsX = 128;
constexpr int kReaderThreads = 4, kMaxReaderThreads = 16, kDiskReaderThreads = 32, kGpuReaderNice = 10;

/// The field-data array that names the file (MarkOutOfCore), or null.
vtkStringArray* MarkerArray(vtkFieldData* fd)
{
  for (int k = 0; fd && k < fd->GetNumberOfArrays(); ++k)
  {
    auto* array = vtkStringArray::SafeDownCast(fd->GetAbstractArray(k));
    if (array && array->GetNumberOfValues() >= 3 && array->GetValue(0) == kOutOfCoreMarker)
      return array;
  }
  return nullptr;
}

uint64_t Fnv(uint64_t h, const void* data, size_t size)
{
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i)
    h = (h ^ bytes[i]) * 1099511628211ull;
  return h;
}

/// The blocks' shape: bricks long in x, CellsX (up to kBrickCellsX, kGpuBrickCellsX beside a GPU trainer) by 2 x 2
/// cells, the longest of which the buffer's share holds kBlocksPerBatchSample times the batch size (else 2^3-cell
/// cubes, as for a small budget). A block is read a z-slice at a time (one read of its 3 rows where they lie close:
/// VolumeFileReader kSliceSpanBytes), so a brick brings many more cells per read than a cube: 128 x 2 x 2 cells are 3
/// reads for 512 cells, 2^3 cells 3 reads for 8. What the network needs is the whole volume seen again and again up to the end of the run, when the rate is
/// low: with cubes and the reads of a step (kRowReadsPerStep) the buffer saw a small part of the volume between two
/// turnovers and the network fitted the part it held (the H100's 2 GB crop under 512 MiB: 2.47 M resident 2^3-cell
/// blocks, 4% of the cells, 3640 replaced a step, 2.95 dB below memory at 10k steps). Measured on a 256^3 float32
/// file of the same family, 10 MiB buffer, batch 4096, 4000 CPU steps, 228 blocks replaced a step
/// (results/outofcore_gap_2026-11-27.md): 2^3-cell cubes 41.47 dB (37% of the blocks ever resident), bricks of
/// 16 x 2 x 2 cells 43.43, 32 x 2 x 2 43.83, 64 x 2 x 2 44.19-44.58 dB (every block resident at times, one block a
/// sample of the batch); in memory 44.94 dB. On the H100's crop (800^3 float32, 320 MiB of blocks, batch 65536, 14
/// readers, the engine's nvBenchOutOfCoreGap, results/outofcore_2026-11-27d.md): 64 x 2 x 2 bricks 57.04-58.01 dB
/// (mean 57.56), 128 x 2 x 2 57.59-58.56 (mean 57.97; their reads bring twice the cells for the same calls), in
/// memory 58.41 dB. Beside the CPU engine the reads keep up (no swap missed) and the longer brick only draws a batch
/// from fewer places: nv.pv.NeuralOutOfCoreLarge (2 GiB file, 128 MiB, batch 8192, 400 steps) 33.01-33.08 dB with
/// 128 x 2 x 2 against 33.85 with 64 x 2 x 2 (34.10 in memory).
struct BlockShape
{
  int CellsX = 2;
  int Cells = 2; ///< along y and z
};

BlockShape BlockShapeFor(int64_t bufferBytes, int batchSize, bool gpuTrainer)
{
  const double wanted = double(std::max(1, batchSize)) * kBlocksPerBatchSample;
  for (int cellsX = gpuTrainer ? kGpuBrickCellsX : kBrickCellsX; cellsX >= 4; cellsX /= 2)
    if (double(bufferBytes) / double(nv::BlockBuffer::bytesPerSlot(cellsX, 2, 2)) >= wanted)
      return BlockShape{ cellsX, 2 };
  return BlockShape{ 2, 2 };
}

/// Slots the readers fill while the others are drawn from: twice the blocks replaced per step, which cost about
/// kRowReadsPerStep row reads (a block is (cells + 1)^2 rows; the readers never hold a step up: what they have not
/// read by then is swapped in later), at least kMinBlocksPerStep, never more than a quarter of the slots.
/// Replacing many blocks a step matters as much as many blocks (a 32 MiB file under 2 MiB, 4^3-cell blocks: 64 a step
/// 26.9 dB, 1024 a step 29.9 dB; the 2 GiB test's 3^3-cell blocks: 512 a step 32.8-33.4 dB, 2048 a step 33.7 dB).
int64_t LoadingSlotsFor(int64_t bufferBytes, const BlockShape& shape)
{
  const int64_t side = shape.Cells + 1;
  const int64_t slots = bufferBytes / nv::BlockBuffer::bytesPerSlot(shape.CellsX, shape.Cells, shape.Cells);
  const int64_t perStep = std::max<int64_t>(kMinBlocksPerStep, kRowReadsPerStep / (side * side));
  return std::max<int64_t>(2, std::min(2 * perStep, slots / 4));
}

/// Owns what an out-of-core trainer draws from: the file, its block buffer and the batch source on it; after each
/// step's swaps the buffer's read figures go to the file (the output's NeuralBuffer* arrays).
struct BufferedFile final : public nv::BatchSource
{
  BufferedFile(const std::shared_ptr<const OutOfCoreFile>& file, const nv::BlockBufferConfig& config,
    const nv::ValueRange& range)
    : File(file)
    , Buffer(file->Layout, config)
    , Source(Buffer, range, config.loadingSlots / 2)
  {
    this->File->BufferFirstFillBytes = this->Buffer.stats().bytesRead;
    this->publish();
  }
  void prepareStep(uint64_t step) override
  {
    this->Source.prepareStep(step);
    this->publish();
  }
  int64_t fill(uint64_t seed, uint64_t step, int64_t first, int64_t count, float* xyz, float* targets,
    uint8_t* valid) const override
  {
    return this->Source.fill(seed, step, first, count, xyz, targets, valid);
  }
  void publish() const
  {
    const nv::BlockBufferStats stats = this->Buffer.stats();
    this->File->BufferBytesRead = stats.bytesRead;
    this->File->BufferBytesTransferred = stats.bytesTransferred;
    this->File->BufferSwapsMissed = stats.swapsMissed;
  }
  std::shared_ptr<const OutOfCoreFile> File;
  nv::BlockBuffer Buffer;
  nv::BlockBufferSource Source;
};

/// The PSNR probe: random rows of the file (sequential reads), every stride-th sample of each, normalised.
std::unique_ptr<nv::PsnrProbe> RowProbe(const OutOfCoreFile& file, const nv::ValueRange& range, uint64_t seed)
{
  const nv::VolumeFileLayout& layout = file.Layout;
  const int64_t nx = layout.dims[0], ny = layout.dims[1], nz = layout.dims[2];
  const int64_t probeBytes = file.BudgetBytes * kProbeEighths / 8;
  // Each kept sample holds its position and value (16 bytes); a row read at once holds nx doubles.
  const int64_t samples = std::min<int64_t>(kProbeSamples, std::max<int64_t>(0, (probeBytes - nx * 8) / 16));
  if (samples < 256)
    NV_THROW("the MemoryBudget of " + nv::formatBytes(file.BudgetBytes) + " cannot hold one row of the file (" +
      std::to_string(nx) + " samples) and a PSNR probe; raise MemoryBudget");
  const int64_t rows = std::min(ny * nz, std::max<int64_t>(64, (samples + nx - 1) / nx));
  const int64_t stride = std::max<int64_t>(1, (rows * nx + samples - 1) / samples);
  std::vector<double> row(static_cast<size_t>(nx));
  std::vector<float> xyz, values;
  xyz.reserve(static_cast<size_t>(3 * samples + 3 * nx));
  values.reserve(static_cast<size_t>(samples + nx));
  auto unit = [](int64_t i, int64_t n) { return n > 1 ? float(double(i) / double(n - 1)) : 0.5f; };
  for (int64_t r = 0; r < rows; ++r)
  {
    const uint64_t h = nv::mix64(nv::mix64(seed ^ 0x524f5750524f4245ull) + uint64_t(r));
    const int64_t line = static_cast<int64_t>((static_cast<unsigned __int128>(h) * uint64_t(ny * nz)) >> 64);
    const int64_t y = line % ny, z = line / ny;
    file.Reader->readBox({ 0, y, z }, { nx, 1, 1 }, row.data());
    for (int64_t i = (r * 7919) % stride; i < nx; i += stride)
    {
      xyz.insert(xyz.end(), { unit(i, nx), unit(y, ny), unit(z, nz) });
      values.push_back(std::isfinite(row[size_t(i)]) ? static_cast<float>(range.fraction(row[size_t(i)]))
                                                     : std::numeric_limits<float>::quiet_NaN());
    }
  }
  return std::unique_ptr<nv::PsnrProbe>(new nv::PsnrProbe(xyz, values, kProbeSamples));
}
} // namespace

OutOfCorePhaseLog::OutOfCorePhaseLog(const std::string& phase, const std::string& detail)
  : Phase(phase)
  , Start(std::chrono::steady_clock::now())
{
  vtkLogF(INFO, "Neural Compress (out of core): %s started%s%s", this->Phase.c_str(), detail.empty() ? "" : ", ",
    detail.c_str());
}

void OutOfCorePhaseLog::Progress(double fraction)
{
  const int tenth = static_cast<int>(fraction * 10.0);
  if (tenth <= this->LoggedTenth || tenth >= 10)
    return;
  this->LoggedTenth = tenth;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - this->Start).count();
  vtkLogF(INFO, "Neural Compress (out of core): %s %d%% (%.1f s)", this->Phase.c_str(), tenth * 10, seconds);
}

double OutOfCorePhaseLog::Finish()
{
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - this->Start).count();
  vtkLogF(INFO, "Neural Compress (out of core): %s done in %.2f s", this->Phase.c_str(), seconds);
  return seconds;
}

bool OutOfCoreRequestOf(vtkDataObject* input, OutOfCoreRequest& request)
{
  auto* image = vtkImageData::SafeDownCast(input);
  vtkStringArray* marker = MarkerArray(image ? image->GetFieldData() : nullptr);
  request.Path = marker ? marker->GetValue(1) : std::string();
  request.Array = marker ? marker->GetValue(2) : std::string();
  return !request.Path.empty();
}

uint64_t OutOfCoreStamp(const OutOfCoreRequest& file, const int extent[6])
{
  uint64_t h = Fnv(1469598103934665603ull, file.Path.data(), file.Path.size());
  h = Fnv(h, file.Array.data(), file.Array.size());
  h = Fnv(h, extent, 6 * sizeof(int));
  struct stat info;
  if (::stat(file.Path.c_str(), &info) == 0)
  {
    const int64_t facts[3] = { int64_t(info.st_size), int64_t(info.st_mtim.tv_sec), int64_t(info.st_mtim.tv_nsec) };
    h = Fnv(h, facts, sizeof(facts));
  }
  return h;
}

std::string OutOfCoreSummary(const nv::VolumeFileLayout& layout)
{
  std::ostringstream text;
  text << layout.format << ", " << layout.dims[0] << " x " << layout.dims[1] << " x " << layout.dims[2] << " "
       << nv::scalarTypeName(layout.type) << ", " << (layout.bigEndian ? "big" : "little") << " endian, "
       << nv::formatBytes(layout.bytes()) << " ('" << layout.arrayName << "')";
  if (layout.fileBytes() > layout.bytes())
    text << ", the piece at sample " << layout.boxOrigin[0] << ", " << layout.boxOrigin[1] << ", "
         << layout.boxOrigin[2] << " of the file's " << layout.fileDim(0) << " x " << layout.fileDim(1) << " x "
         << layout.fileDim(2) << " (" << nv::formatBytes(layout.fileBytes()) << ")";
  return text.str();
}

nv::VolumeFileLayout OutOfCorePiece(const nv::VolumeFileLayout& layout, const int extent[6])
{
  int64_t origin[3], size[3];
  bool whole = true;
  for (int a = 0; a < 3; ++a)
  {
    origin[a] = extent[2 * a];
    size[a] = int64_t(extent[2 * a + 1]) - extent[2 * a] + 1;
    if (size[a] < 1 || origin[a] < 0 || origin[a] + size[a] > layout.dims[a])
      throw nv::Error("the out-of-core input's extent " + std::to_string(extent[0]) + ".." + std::to_string(extent[1]) +
        ", " + std::to_string(extent[2]) + ".." + std::to_string(extent[3]) + ", " + std::to_string(extent[4]) + ".." +
        std::to_string(extent[5]) + " does not lie in the file's samples (" + OutOfCoreSummary(layout) +
        "): the file changed since its header was read; update the reader");
    whole = whole && origin[a] == 0 && size[a] == layout.dims[a];
  }
  return whole ? layout : nv::volumeFileSubBox(layout, origin, size);
}

PieceSums MeasureOutOfCorePiece(nv::NetworkSession& session, const OutOfCoreFile& file, const FieldInfo& field,
  const int owned[6], const int whole[6], double modelBytes)
{
  int lo[3], hi[3];
  double samples = 0.0, wholeSamples = 0.0;
  if (!ExclusiveSamples(field.InputExtent, file.Layout.dims, owned, whole, false, lo, hi, samples, wholeSamples))
    return PieceSums();
  const int64_t from[3] = { lo[0], lo[1], lo[2] }, to[3] = { hi[0], hi[1], hi[2] };
  OutOfCorePhaseLog log("this rank's own samples", std::to_string(int64_t(samples)) + " samples of its piece");
  const nv::ErrorStats error = nv::measureBoxOnFile(
    session, *file.Reader, from, to, field.Stats.min, field.Stats.max, OutOfCoreSlabBytes(file));
  log.Finish();
  const double bytesPerSample = static_cast<double>(nv::scalarSize(file.Layout.type));
  return SumsOfMeasurement(error, field.Stats.min, field.Stats.max, samples, wholeSamples, bytesPerSample, modelBytes);
}

void MarkOutOfCore(vtkImageData* image, const nv::VolumeFileLayout& layout, const std::string& requestedArray)
{
  vtkNew<vtkStringArray> marker;
  marker->SetName(layout.arrayName.empty() ? "Scalars" : layout.arrayName.c_str());
  for (const std::string& value : { std::string(kOutOfCoreMarker), layout.headerPath, requestedArray,
         OutOfCoreSummary(layout) })
    marker->InsertNextValue(value);
  image->GetFieldData()->AddArray(marker);
}

int64_t OutOfCoreBudgetBytes(double memoryBudgetMiB, int64_t fileBytes, std::string& reason, int processesOnHost)
{
  const int ranks = std::max(1, processesOnHost);
  const nv::HostMemoryBudget host = nv::hostMemoryBudget();
  std::ostringstream text;
  if (memoryBudgetMiB > 0.0)
  {
    const double asked = memoryBudgetMiB * double(1 << 20);
    if (asked > double(host.bytes))
      NV_THROW("MemoryBudget " + nv::formatBytes(int64_t(std::min(asked, 9.0e18))) + " exceeds what this process may "
        "allocate (" + nv::formatBytes(host.bytes) + ": " + host.reason + "); lower MemoryBudget or set it to 0 "
        "(automatic)");
    text << "MemoryBudget " << nv::formatBytes(int64_t(asked));
    reason = text.str();
    return int64_t(asked);
  }
  const int64_t share = host.bytes == std::numeric_limits<int64_t>::max()
    ? int64_t(1) << 30
    : static_cast<int64_t>(double(host.bytes) * kAutomaticBudgetShare / ranks);
  // A file the budget holds twice over needs no more (its blocks, the probe and the slabs all fit).
  const int64_t budget = std::max<int64_t>(int64_t(16) << 20, std::min(share, nv::saturatingMul(fileBytes, 3)));
  text << "automatic: " << nv::formatBytes(budget) << " (at most " << int(kAutomaticBudgetShare * 100) << "% of "
       << nv::formatBytes(host.bytes) << (host.reason.empty() ? "" : ", " + host.reason)
       << (ranks > 1 ? ", shared by the " + std::to_string(ranks) + " ranks on this host" : std::string()) << ")";
  reason = text.str();
  return budget;
}

void CheckOutOfCoreStorage(const OutOfCoreFile& file)
{
  const std::shared_ptr<const nv::VolumeBoxSource>& source = file.Layout.boxSource;
  const int64_t share = file.BudgetBytes * kChunkEighths / 8;
  if (!source || source->workingBytes() <= share)
    return;
  throw nv::Error("'" + file.Layout.headerPath + "' (" + source->storage() + "): decoding its chunks holds up to " +
    nv::formatBytes(source->workingBytes()) + ", more than the " + nv::formatBytes(share) + " the memory budget (" +
    file.BudgetReason + ") keeps for it: a chunk layout this budget cannot stream. Raise MemoryBudget to at least " +
    nv::formatBytes(source->workingBytes() * 8 / kChunkEighths) + " or repack the dataset with smaller chunks "
    "(h5repack -l CHUNK=64x64x64)");
}

int64_t OutOfCoreSlabBytes(const OutOfCoreFile& file)
{
  return std::max<int64_t>(1, file.BudgetBytes * kSlabEighths / 8);
}

int OutOfCoreReaderThreads(bool gpuTrainer, nv::PageCacheUse reads)
{
  if (reads != nv::PageCacheUse::Normal)
    return kDiskReaderThreads;
  if (!gpuTrainer)
    return kReaderThreads;
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(kReaderThreads, std::min(kMaxReaderThreads, cores - 2));
}

std::shared_ptr<nv::TrainingData> OutOfCoreTrainingData(
  const std::shared_ptr<const OutOfCoreFile>& file, const nv::VolumeStats& stats, uint64_t seed, int batchSize)
{
  const nv::VolumeFileLayout& layout = file->Layout;
  auto data = std::make_shared<nv::TrainingData>();
  data->Field.View.data = nullptr; // never in memory: the trainer draws from the block buffer
  data->Field.View.type = layout.type;
  std::copy(layout.dims, layout.dims + 3, data->Field.View.dims);
  data->Field.View.valueMin = stats.min;
  data->Field.View.valueMax = stats.max;
  data->Field.RawBytes = layout.bytes();
  const nv::ValueRange range(stats.min, stats.max);
  nv::BlockBufferConfig config;
  config.memoryBudgetBytes = file->BudgetBytes * kBufferEighths / 8;
  const BlockShape shape = BlockShapeFor(config.memoryBudgetBytes, batchSize, file->GpuTrainer);
  config.blockCells = shape.Cells;
  config.blockCellsX = shape.CellsX;
  config.loadingSlots = static_cast<int>(LoadingSlotsFor(config.memoryBudgetBytes, shape));
  config.readerThreads = std::max(1, file->ReaderThreads);
  config.readerNice = file->GpuTrainer ? kGpuReaderNice : 0;
  config.seed = seed;
  config.pageCache = file->BufferReads;
  const std::string shapeText = std::to_string(shape.CellsX) + " x " + std::to_string(shape.Cells) + " x " +
    std::to_string(shape.Cells) + "-cell blocks";
  OutOfCorePhaseLog fillLog("first fill of the block buffer",
    shapeText + " in " + nv::formatBytes(config.memoryBudgetBytes));
  auto buffered = std::make_shared<BufferedFile>(file, config, range);
  file->FirstFillSeconds = fillLog.Finish();
  const nv::BlockBufferStats filled = buffered->Buffer.stats();
  std::ostringstream d;
  d.precision(3);
  d << "out of core: " << OutOfCoreSummary(layout) << "; block buffer of " << filled.residentBlocks << " resident "
    << shapeText << ", up to " << config.loadingSlots / 2 << " replaced a step by " << config.readerThreads
    << " reader threads ("
    << nv::formatBytes(filled.bufferBytes) << " of the " << file->BudgetReason << "); value-range pass "
    << file->ValueRangeSeconds.load() << " s, first fill " << file->FirstFillSeconds.load() << " s";
  data->Field.Description = d.str();
  data->Batches = buffered;
  data->Probe = RowProbe(*file, range, seed);
  return data;
}

uint64_t OutOfCoreKey(const OutOfCoreFile& file, const FieldInfo& field, const Settings& settings)
{
  const nv::VolumeFileLayout& layout = file.Layout;
  std::ostringstream identity;
  identity.precision(17);
  identity << "out-of-core " << layout.headerPath << '|' << layout.dataPath << '|' << layout.dataOffset << '|'
           << static_cast<int>(layout.type) << '|' << layout.bigEndian << '|' << layout.arrayName << '|'
           << file.BudgetBytes;
  if (layout.fileBytes() > layout.bytes()) // a rank's piece (the whole file's key is unchanged by it)
    identity << "|piece " << layout.boxOrigin[0] << ',' << layout.boxOrigin[1] << ',' << layout.boxOrigin[2] << " of "
             << layout.fileDim(0) << ',' << layout.fileDim(1) << ',' << layout.fileDim(2);
  struct stat info;
  if (::stat(layout.dataPath.c_str(), &info) == 0)
    identity << '|' << int64_t(info.st_size) << '|' << int64_t(info.st_mtim.tv_sec) << '.'
             << int64_t(info.st_mtim.tv_nsec);
  const std::string text = identity.str();
  nv::VolumeView keyView; // the file's identity stands for its values (which are never all read for a key)
  keyView.data = text.data();
  keyView.type = nv::ScalarType::UInt8;
  keyView.dims[0] = static_cast<int64_t>(text.size());
  keyView.dims[1] = keyView.dims[2] = 1;
  return TrainingKey(keyView, field, settings) ^ Fnv(1469598103934665603ull, layout.dims, sizeof(layout.dims));
}

void CheckOutOfCoreDecode(const FieldInfo& field, int outputMode)
{
  if (!field.OutOfCore || outputMode == 0)
    return;
  const int* dims = field.Geometry.DecodedDims;
  const int64_t count = nv::saturatingMul(nv::saturatingMul(dims[0], dims[1]), dims[2]);
  // The decoded values (float or double) and, for the input's type, its copy: at most 16 bytes a sample.
  const int64_t bytes = nv::saturatingMul(count, 16);
  if (bytes <= field.OutOfCore->BudgetBytes)
    return;
  std::ostringstream text;
  text << "the decoded output of an out-of-core input (" << dims[0] << " x " << dims[1] << " x " << dims[2]
       << " samples, up to " << nv::formatBytes(bytes) << ") exceeds its memory budget ("
       << field.OutOfCore->BudgetReason << "): the file's field is never loaded. Choose OutputMode 'Network only' "
       << "(the Neural Volume representation renders the network), a coarser OutputResolution or a larger "
       << "MemoryBudget.";
  throw nv::Error(text.str());
}

nv::ErrorStats MeasureOutOfCore(nv::NetworkSession& session, const OutOfCoreFile& file, double valueMin,
  double valueMax, const std::function<bool()>& abort, const std::function<void(double)>& progress)
{
  OutOfCorePhaseLog log("exact pass", "every voxel of " + nv::formatBytes(file.Layout.bytes()));
  const nv::ErrorStats figures = nv::measureOnFile(session, *file.Reader, valueMin, valueMax,
    OutOfCoreSlabBytes(file), [&abort, &progress, &log](double fraction) {
      log.Progress(fraction);
      if (progress)
        progress(fraction);
      return !(abort && abort());
    });
  file.ExactPassSeconds = log.Finish();
  return figures;
}

} // namespace vtkNeuralCompressInternals
