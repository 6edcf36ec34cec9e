// The training run's log in bounded memory (Core/TrainingLog.h): a row per step while short, at most 2 x kMaxRows
// rows over a long run with its first and last rows exact and loss and PSNR rows spread over the whole run, chunk
// ends kept until the next row (so a probe's PSNR lands on its own step), and truncation for a rollback.
#include "Core/TrainingLog.h"
#include "TestHarness.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

using namespace nv;

namespace
{
LogRow row(int64_t step)
{
  return LogRow{ step, 1.0 / double(step + 1), 0.01, 0.001 * double(step), std::numeric_limits<double>::quiet_NaN() };
}

/// `steps` steps from `first` in chunks of `chunk`, a probe (PSNR = step / 1000) at every `probeEvery`-th step.
void train(TrainingLog& log, int64_t first, int64_t steps, int64_t chunk, int64_t probeEvery)
{
  for (int64_t s = first; s < first + steps; ++s)
  {
    const bool chunkEnd = (s - first + 1) % chunk == 0;
    log.append(row(s), chunkEnd);
    if (chunkEnd && s % probeEvery == 0)
      log.setLastPsnr(double(s) / 1000.0);
  }
}
} // namespace

NV_TEST(a_short_run_keeps_a_row_per_step)
{
  TrainingLog log;
  train(log, 1, 5000, 10, 100);
  EXPECT_TRUE(log.rows().size() == 5000);
  EXPECT_TRUE(log.stride() == 1);
  for (size_t i = 0; i < log.rows().size(); ++i)
    EXPECT_TRUE(log.rows()[i].Step == int64_t(i) + 1);
  EXPECT_TRUE(log.rows()[99].PSNR == 0.1 && std::isnan(log.rows()[98].PSNR)); // the probe's row is its step's
}

NV_TEST(a_long_run_stays_bounded_and_spans_the_run)
{
  TrainingLog log;
  const int64_t steps = 3000000;
  train(log, 1, steps, 16, 400);
  const std::vector<LogRow>& rows = log.rows();
  EXPECT_TRUE(rows.size() <= 2 * TrainingLog::kMaxRows);
  EXPECT_TRUE(rows.size() >= TrainingLog::kMaxRows / 2);
  EXPECT_TRUE(rows.front().Step == 1 && rows.back().Step == steps);
  // Steps increase; loss rows and probe rows are found in every tenth of the run.
  int lossIn[10] = {}, probesIn[10] = {};
  for (size_t i = 0; i < rows.size(); ++i)
  {
    if (i > 0)
      EXPECT_TRUE(rows[i].Step > rows[i - 1].Step);
    const int tenth = int(std::min<int64_t>(9, (rows[i].Step - 1) * 10 / steps));
    if (std::isnan(rows[i].PSNR))
      ++lossIn[tenth];
    else
    {
      ++probesIn[tenth];
      EXPECT_TRUE(rows[i].PSNR == double(rows[i].Step) / 1000.0); // a probe's PSNR stays on its step
    }
  }
  for (int t = 0; t < 10; ++t)
    EXPECT_TRUE(lossIn[t] >= 100 && probesIn[t] >= 20);
  EXPECT_TRUE(log.stride() > 1 && (log.stride() & (log.stride() - 1)) == 0);
}

NV_TEST(a_chunk_end_off_the_stride_lasts_until_the_next_row)
{
  TrainingLog log;
  train(log, 1, 200000, 7, 1000000000); // no probes: stride > 1 after the first compaction
  const int64_t stride = log.stride();
  EXPECT_TRUE(stride > 1);
  const int64_t next = 200001;
  const int64_t offStride = next % stride == 0 ? next + 1 : next;
  log.append(row(offStride), true);
  EXPECT_TRUE(log.rows().back().Step == offStride); // kept while it is the last
  log.append(row(offStride + 1), false);
  EXPECT_TRUE(log.rows().back().Step != offStride); // dropped: no PSNR came for it
  log.append(row(offStride + 2), true);
  log.setLastPsnr(42.0);
  log.append(row(offStride + 3), false);
  bool found = false;
  for (const LogRow& r : log.rows())
    found = found || (r.Step == offStride + 2 && r.PSNR == 42.0);
  EXPECT_TRUE(found); // with a PSNR it stays
}

NV_TEST(truncation_forgets_the_steps_after_a_rollback_point)
{
  TrainingLog log;
  train(log, 1, 100000, 8, 500);
  log.truncateAfter(54321);
  EXPECT_TRUE(!log.rows().empty() && log.rows().back().Step <= 54321);
  for (const LogRow& r : log.rows())
    EXPECT_TRUE(r.Step <= 54321);
  log.append(row(54322), true);
  EXPECT_TRUE(log.rows().back().Step == 54322);
}

NV_TEST_MAIN()
