// NeuralVolume engine: the bounded training log (see TrainingLog.h).
#include "TrainingLog.h"

#include <cmath>

namespace nv
{

void TrainingLog::append(const LogRow& row, bool chunkEnd)
{
  if (this->LastIsChunkEnd && !this->Rows.empty() && std::isnan(this->Rows.back().PSNR))
  {
    this->Rows.pop_back(); // it was kept only until the next row came
  }
  this->LastIsChunkEnd = false;
  const bool onStride = row.Step % this->Stride == 0;
  if (!onStride && !chunkEnd)
  {
    return;
  }
  this->Rows.push_back(row);
  this->LastIsChunkEnd = !onStride;
  if (this->Rows.size() > 2 * kMaxRows)
  {
    this->compact();
  }
}

void TrainingLog::setLastPsnr(double psnr)
{
  if (!this->Rows.empty())
  {
    this->Rows.back().PSNR = psnr;
  }
}

void TrainingLog::truncateAfter(int64_t step)
{
  while (!this->Rows.empty() && this->Rows.back().Step > step)
  {
    this->Rows.pop_back();
  }
  this->LastIsChunkEnd = false;
}

void TrainingLog::compact()
{
  // Loss rows: those on the doubled stride. Probe rows (a PSNR): every other one. The first and the last stay.
  const int64_t stride = 2 * this->Stride;
  std::vector<LogRow> kept;
  kept.reserve(this->Rows.size() / 2 + 2);
  size_t probes = 0;
  for (size_t i = 0; i < this->Rows.size(); ++i)
  {
    const LogRow& row = this->Rows[i];
    const bool edge = i == 0 || i + 1 == this->Rows.size();
    bool keep = edge;
    if (!std::isnan(row.PSNR))
    {
      keep = keep || probes % 2 == 0;
      ++probes;
    }
    else
    {
      keep = keep || row.Step % stride == 0;
    }
    if (keep)
    {
      kept.push_back(row);
    }
  }
  this->Rows.swap(kept);
  this->Stride = stride;
}

} // namespace nv
