// NeuralVolume engine: the log of a training run (TrainingRun.h) in bounded memory. One row per step while the run
// is short; past kMaxRows rows it thins itself: every compaction halves the rows (loss rows keep every other step on
// a stride that doubles, probe rows with a PSNR keep every other probe) and later loss rows are kept on the new
// stride. A long run's log (2500 steps a second for an hour: 9 M rows, 360 MB, copied whole at every publish and
// turned into the Training Log table by every live refresh of the GUI) stays at most 2 x kMaxRows rows spread over
// the whole run; the first row, the last row and the rollback point stay exact.
#pragma once

#include "RunStatus.h" // LogRow

#include <cstdint>
#include <vector>

namespace nv
{

class TrainingLog
{
public:
  static constexpr size_t kMaxRows = 8192;

  /// A step's row; `chunkEnd`: the last step of a chunk of steps, kept until the next row arrives (a probe may give
  /// it a PSNR, then it stays) even when the stride would drop it.
  void append(const LogRow& row, bool chunkEnd);
  /// The PSNR measured at the last row's step.
  void setLastPsnr(double psnr);
  /// Forget the rows after `step` (a rollback to the network of that step).
  void truncateAfter(int64_t step);
  const std::vector<LogRow>& rows() const { return this->Rows; }
  /// Steps between kept loss rows (1 until the first compaction; a power of two).
  int64_t stride() const { return this->Stride; }

private:
  void compact();

  std::vector<LogRow> Rows;
  int64_t Stride = 1;
  bool LastIsChunkEnd = false; ///< the last row is there only as a chunk's end (off the stride, no PSNR)
};

} // namespace nv
