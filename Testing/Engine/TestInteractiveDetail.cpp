// The level of detail of paced interactive renders (Core/InteractiveDetail.h): late frames whose engine time is a
// large part of the period step the image down, late frames the engine is not to blame for do not, frames with time
// to spare step it back up, and unpaced or non-finite inputs give full detail.
#include "Core/InteractiveDetail.h"
#include "TestHarness.h"

#include <cmath>
#include <limits>

using nv::InteractiveDetail;

namespace
{
constexpr double kPeriod = 1.0 / 60.0;
} // namespace

NV_TEST(steps_down_when_the_engine_is_late)
{
  InteractiveDetail detail;
  // 5 ms late, 8 ms of GPU time a frame: the third late frame steps down, the sixth again, then the floor.
  double factor = 1.0;
  for (int k = 0; k < 2; ++k)
    factor = detail.next(0.005, 0.008, kPeriod);
  EXPECT_TRUE(factor == 1.0);
  factor = detail.next(0.005, 0.008, kPeriod);
  EXPECT_TRUE(factor == 0.7);
  for (int k = 0; k < 3; ++k)
    factor = detail.next(0.005, 0.008, kPeriod);
  EXPECT_TRUE(factor == 0.5);
  for (int k = 0; k < 10; ++k)
    factor = detail.next(0.005, 0.008, kPeriod);
  EXPECT_TRUE(factor == 0.5 && detail.level() == InteractiveDetail::kLevels - 1);
}

NV_TEST(late_without_the_engine_keeps_detail)
{
  InteractiveDetail detail;
  // Late frames with 1 ms of engine time (the application or the display is slow): shrinking would not help.
  for (int k = 0; k < 20; ++k)
    EXPECT_TRUE(detail.next(0.008, 0.001, kPeriod) == 1.0);
  // An on-time frame breaks a late streak.
  detail.next(0.005, 0.008, kPeriod);
  detail.next(0.005, 0.008, kPeriod);
  detail.next(0.0, 0.008, kPeriod);
  EXPECT_TRUE(detail.next(0.005, 0.008, kPeriod) == 1.0);
}

NV_TEST(steps_back_up_with_time_to_spare)
{
  InteractiveDetail detail;
  for (int k = 0; k < 6; ++k)
    detail.next(0.005, 0.008, kPeriod);
  EXPECT_TRUE(detail.level() == 2);
  // Waiting 10 ms of the 16.7 for its slot: 30 such frames step up one level.
  double factor = 0.0;
  for (int k = 0; k < InteractiveDetail::kEarlyFrames - 1; ++k)
    factor = detail.next(-0.010, 0.002, kPeriod);
  EXPECT_TRUE(factor == 0.5);
  EXPECT_TRUE(detail.next(-0.010, 0.002, kPeriod) == 0.7);
  // A wait of 3 ms (less than the spare fraction) does not count.
  for (int k = 0; k < 100; ++k)
    factor = detail.next(-0.003, 0.002, kPeriod);
  EXPECT_TRUE(factor == 0.7);
}

NV_TEST(unpaced_and_non_finite)
{
  InteractiveDetail detail;
  for (int k = 0; k < 6; ++k)
    detail.next(0.005, 0.008, kPeriod);
  EXPECT_TRUE(detail.level() == 2);
  EXPECT_TRUE(detail.next(0.005, 0.008, 0.0) == 1.0 && detail.level() == 0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < 10; ++k)
    EXPECT_TRUE(detail.next(nan, nan, kPeriod) == 1.0);
  EXPECT_TRUE(detail.next(0.005, 0.008, nan) == 1.0);
}

NV_TEST_MAIN()
