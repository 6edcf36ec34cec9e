// Private to NeuralVolume::Filters: Neural Compress on a file it never loads (issue 22). The out-of-core reader
// (vtkNeuralOutOfCoreReader.h) outputs the file's geometry without samples and names the file in its field data;
// Neural Compress then trains from the engine's random block buffer on that file (Cuda/OutOfCore/BlockBuffer.h, within
// MemoryBudget), estimates the PSNR on random rows of it while training, and measures its exact figures in one
// streamed pass over every voxel (Cuda/OutOfCore/FileMeasure.h) at the end of a phase or on MeasureNow.
// Under MPI the reader's output is an image like any other (vtkNeuralCompressPartition.h): each rank asks for its padded
// piece and everything here -- passes, block buffer, probe, the measurement of its own samples -- reads only that
// sub-box of the file (OutOfCorePiece, nv::volumeFileSubBox).
#ifndef vtkNeuralOutOfCoreInput_h
#define vtkNeuralOutOfCoreInput_h

#include "OutOfCore/VolumeFileLayout.h"
#include "OutOfCore/VolumeFileReader.h"
#include "Core/Engine.h"
#include "Core/TrainingData.h"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>
#include <functional>
#include <memory>
#include <string>

class vtkDataObject;
class vtkImageData;

namespace nv
{
class NetworkSession;
}

namespace vtkNeuralCompressInternals
{
struct FieldInfo;
struct OutOfCoreFile;
struct PieceSums;
struct Settings;

/// The reader's output names the file in one field-data string array named after the file's field (so that Neural
/// Compress's array selection shows that name): { kOutOfCoreMarker, file path, the array asked for (a .vti point
/// array, an HDF5 dataset; empty: the file's own choice), the file's summary }. No such array: not an out-of-core input.
constexpr const char* kOutOfCoreMarker = "NeuralOutOfCoreFile";

/// The file an out-of-core reader's output stands for.
struct OutOfCoreRequest
{
  std::string Path;
  std::string Array;
};

/// True (with the file) when `input` is an out-of-core reader's output.
bool OutOfCoreRequestOf(vtkDataObject* input, OutOfCoreRequest& request);

/// What identifies an out-of-core input between executions (the training's InputIdentity::MTime): the file named, its
/// array, the extent asked (a rank's piece) and the header file's size and modification time -- not the reader's
/// output object, whose modification time moves whenever the pipeline executes the reader again: each live refresh
/// then prepared the file again on a background thread (a value-range pass and a block buffer's first fill; in the GUI
/// 31 in 40 s while the training crawled, 13 steps). A
/// detached data file changed under an unchanged header is seen when the training starts again for another reason
/// (OutOfCoreKey stats it).
uint64_t OutOfCoreStamp(const OutOfCoreRequest& file, const int extent[6]);

/// The reader's output: the file's geometry, no samples, the file named in field data (with its summary figures).
void MarkOutOfCore(vtkImageData* image, const nv::VolumeFileLayout& layout, const std::string& requestedArray);

/// "NRRD (detached header), 64 x 64 x 64 uint16, big endian, 524 kB"; a piece adds where it lies in the file.
std::string OutOfCoreSummary(const nv::VolumeFileLayout& layout);

/// The part of the file `extent` (the out-of-core image's extent, in the file's sample indices) covers: the layout
/// itself when it is the whole file, else its sub-box (nv::volumeFileSubBox): under MPI one rank's padded piece
/// (vtkNeuralCompressPartition.h), so that the rank's passes, block buffer and probe read only that box of the file.
/// Throws nv::Error when the extent is empty or leaves the file (the file changed since the reader's header).
nv::VolumeFileLayout OutOfCorePiece(const nv::VolumeFileLayout& layout, const int extent[6]);

/// Under MPI (vtkNeuralCompressGlobalFigures.h): this rank's sums over the samples of the file it owns alone (the
/// box `owned` within `whole`, point extents), read and decoded in one streamed pass of that box.
PieceSums MeasureOutOfCorePiece(nv::NetworkSession& session, const OutOfCoreFile& file, const FieldInfo& field,
  const int owned[6], const int whole[6], double modelBytes);

/// The block buffer's reader threads: 4 beside the CPU engine's training threads, which take every core; beside a GPU
/// trainer the machine's cores less two, 4 to 16, below its priority (BlockBufferConfig::readerNice); 32 when the
/// reads go to the disk itself (BypassPageCache: the threads wait in the disk's queue, which serves more reads at once
/// the deeper it is). On the H100 crop 4 readers from the page cache (9 preads of 260 B a brick) missed 30.7 M of the
/// swaps asked (results/outofcore_2026-11-27c.md); with O_DIRECT 14 readers read 0.69 of what the disk gives 32
/// (results/outofcore_2026-11-27d.md).
int OutOfCoreReaderThreads(bool gpuTrainer, nv::PageCacheUse reads);

/// An open out-of-core file, shared by the job's training data and its measurements.
struct OutOfCoreFile
{
  nv::VolumeFileLayout Layout;
  std::shared_ptr<nv::VolumeFileReader> Reader;
  int64_t BudgetBytes = 0;  ///< what the block buffer, the probe and a measurement's slabs may hold
  std::string BudgetReason; ///< "MemoryBudget 64 MiB", "automatic: 20% of ..."
  nv::PageCacheUse BufferReads = nv::PageCacheUse::Normal; ///< the block buffer's readers (BypassPageCache)
  int ReaderThreads = 4; ///< the block buffer's reader threads (OutOfCoreReaderThreads)
  bool GpuTrainer = false; ///< trained on the GPU: the readers run at nice +10 (BlockBufferConfig::readerNice)
  /// Seconds of the phases around training (NaN until run; the output's NeuralValueRangeSeconds,
  /// NeuralFirstFillSeconds, NeuralExactPassSeconds): the value-range pass, the block buffer's first fill, the last
  /// exact pass. Set by the passes, which also log their start, progress and end (vtkLogF INFO, on stderr).
  mutable std::atomic<double> ValueRangeSeconds{ std::numeric_limits<double>::quiet_NaN() };
  mutable std::atomic<double> FirstFillSeconds{ std::numeric_limits<double>::quiet_NaN() };
  mutable std::atomic<double> ExactPassSeconds{ std::numeric_limits<double>::quiet_NaN() };
  /// The block buffer's reads (the output's NeuralBufferBytesRead, NeuralBufferBytesTransferred,
  /// NeuralBufferFirstFillBytes, NeuralBufferSwapsMissed; -1 until it exists): the bytes its blocks hold, the bytes the
  /// reads took from the file (whole pages with BypassPageCache), those of the first fill, the replacements a step
  /// asked for while no block was ready. Updated every step.
  mutable std::atomic<int64_t> BufferBytesRead{ -1 };
  mutable std::atomic<int64_t> BufferBytesTransferred{ -1 };
  mutable std::atomic<int64_t> BufferFirstFillBytes{ -1 };
  mutable std::atomic<int64_t> BufferSwapsMissed{ -1 };
};

/// A phase around training on the log (vtkLogF INFO, on stderr; a run stopped midway still tells where it was): its
/// start, each tenth of its progress, its end with its seconds ("Neural Compress (out of core): exact pass 40%").
class OutOfCorePhaseLog
{
public:
  OutOfCorePhaseLog(const std::string& phase, const std::string& detail);
  void Progress(double fraction);
  double Finish(); ///< seconds since the start, logged

private:
  std::string Phase;
  std::chrono::steady_clock::time_point Start;
  int LoggedTenth = 0;
};

/// The bytes of `memoryBudgetMiB` (0: automatic, kAutomaticBudgetShare of what the host may still allocate shared
/// among the `processesOnHost` MPI ranks there, at most the file's -- a rank's piece's -- bytes plus a margin); throws
/// nv::Error when the budget asked exceeds what the host may allocate. An explicit budget is each rank's.
int64_t OutOfCoreBudgetBytes(double memoryBudgetMiB, int64_t fileBytes, std::string& reason, int processesOnHost = 1);
constexpr double kAutomaticBudgetShare = 0.25;

/// A chunked HDF5 dataset whose chunk decoding (VolumeBoxSource::workingBytes) exceeds the budget's share for it (an
/// eighth): throws nv::Error with the figures and the advice. Nothing for raw layouts.
void CheckOutOfCoreStorage(const OutOfCoreFile& file);

/// Bytes of the slabs a streamed pass reads at once (a share of the budget; at least one plane).
int64_t OutOfCoreSlabBytes(const OutOfCoreFile& file);

/// The training data of the file: no field in memory (the view carries its dimensions, type and value range), a
/// block buffer within the budget as the trainer's batch source (blocks small enough that the buffer holds several
/// per sample of a batch of `batchSize`), and a PSNR probe on random rows of the file.
std::shared_ptr<nv::TrainingData> OutOfCoreTrainingData(
  const std::shared_ptr<const OutOfCoreFile>& file, const nv::VolumeStats& stats, uint64_t seed, int batchSize);

/// The training key: the settings, the geometry, the file (path, size, modification time, layout) and the budget.
uint64_t OutOfCoreKey(const OutOfCoreFile& file, const FieldInfo& field, const Settings& settings);

/// A decoded output of an out-of-core input (OutputMode Decoded) must fit its MemoryBudget: throws nv::Error (with
/// the figures and the advice) when it does not. Nothing for other inputs or OutputMode "Network only".
void CheckOutOfCoreDecode(const FieldInfo& field, int outputMode);

/// The session's network over every voxel of the file in one streamed pass (exact PSNR and max error); `abort`
/// polled after each slab (nv::Error "stopped"), `progress` told its fraction.
nv::ErrorStats MeasureOutOfCore(nv::NetworkSession& session, const OutOfCoreFile& file, double valueMin,
  double valueMax, const std::function<bool()>& abort, const std::function<void(double)>& progress);

} // namespace vtkNeuralCompressInternals

#endif
