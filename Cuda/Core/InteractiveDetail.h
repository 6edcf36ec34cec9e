// NeuralVolume engine: the level of detail of interactive renders paced to a display's rate. A view turning at the
// display's rate has one period per frame for everything: the application's own drawing and the display's copy, and
// the engine's GPU time. When frames keep missing their slot while the engine's GPU time is a large part of the
// period, the interactive image steps down (fewer pixels); when frames keep waiting for their slot with time to
// spare, it steps back up. Discrete levels with hysteresis, so a view keeps one image size (one texture each) instead
// of a new size every frame. The still render after an interaction is full size (not this class's business).
//   nv::InteractiveDetail detail;
//   scale = base * detail.next(lateSeconds, engineSeconds, periodSeconds);   // per paced interactive frame
#pragma once

#include <algorithm>

namespace nv
{

class InteractiveDetail
{
public:
  /// Linear image factors of the levels (pixels x1, x0.49, x0.25).
  static constexpr int kLevels = 3;
  static constexpr double kFactors[kLevels] = { 1.0, 0.7, 0.5 };
  /// Consecutive late frames (each later than kLateFraction of a period, with the engine's time above
  /// kEngineFraction of it) that step the detail down; consecutive early frames (each waiting more than kSpareFraction
  /// of a period for its slot) that step it up.
  static constexpr int kLateFrames = 3;
  static constexpr int kEarlyFrames = 30;
  static constexpr double kLateFraction = 0.1;
  static constexpr double kEngineFraction = 0.25;
  static constexpr double kSpareFraction = 0.4;

  /// The factor of the next interactive frame's image. `lateSeconds`: how much later than its slot the frame came
  /// (negative: how long it waits for the slot); `engineSeconds`: the engine's time for the previous frame (its GPU
  /// time, or the engine call's); `periodSeconds`: one slot (1 / the maximum interactive frame rate; <= 0: unpaced,
  /// the detail goes back to full). Non-finite inputs count as neither late nor early.
  double next(double lateSeconds, double engineSeconds, double periodSeconds)
  {
    if (!(periodSeconds > 0.0))
    {
      Level = LateStreak = EarlyStreak = 0;
      return kFactors[0];
    }
    const bool late = lateSeconds > kLateFraction * periodSeconds && engineSeconds > kEngineFraction * periodSeconds;
    const bool early = -lateSeconds > kSpareFraction * periodSeconds;
    LateStreak = late ? LateStreak + 1 : 0;
    EarlyStreak = early ? EarlyStreak + 1 : 0;
    if (LateStreak >= kLateFrames && Level + 1 < kLevels)
    {
      ++Level;
      LateStreak = EarlyStreak = 0;
    }
    else if (EarlyStreak >= kEarlyFrames && Level > 0)
    {
      --Level;
      LateStreak = EarlyStreak = 0;
    }
    return kFactors[Level];
  }

  /// 0 = full detail ... kLevels - 1.
  int level() const { return Level; }

private:
  int Level = 0;
  int LateStreak = 0;
  int EarlyStreak = 0;
};

} // namespace nv
