"""Interactive renders are paced to MaximumInteractiveFrameRate (a display's rate, so that a network training beside
a turning view keeps the time between frames): interactive renders asked for back to back take at least one slot
each, the slots keep their cadence (a frame a little late does not delay the ones after it), still renders are never
held, and 0 lifts the limit."""
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403

nvtest.require_display()
nvtest.load_plugin(globals())
log, check = nvtest.log, nvtest.check

wavelet, network, view, display = nvtest.wavelet_view([96, 96], 0.3)
check(display.MaximumInteractiveFrameRate == 60.0, "the default limit is a display's 60 frames a second (%r)"
      % display.MaximumInteractiveFrameRate)
camera = view.GetActiveCamera()
Render(view)
FRAMES, RATE = 10, 5.0


def seconds_for(render, late_frame=None, late_by=0.0):
    view.SMProxy.InteractiveRender()  # the first frame starts the clock of the slots
    start = time.perf_counter()
    for frame in range(FRAMES):
        if frame == late_frame:
            time.sleep(late_by)
        camera.Azimuth(3.0)
        render()
    return time.perf_counter() - start


display.MaximumInteractiveFrameRate = RATE
paced = seconds_for(lambda: view.SMProxy.InteractiveRender())
log("%d interactive renders at most %.0f a second: %.3f s" % (FRAMES, RATE, paced))
check(paced >= FRAMES / RATE * 0.98, "interactive renders wait for their slots (%.3f s >= %.2f s)"
      % (paced, FRAMES / RATE * 0.98))
# Frame 5 asked for a quarter of a slot after its slot: it takes that slot, and the frames after it keep theirs (the
# whole run still takes 10 slots; pacing from each frame's start would add the quarter slot to every later one).
late = seconds_for(lambda: view.SMProxy.InteractiveRender(), late_frame=5, late_by=1.25 / RATE)
log("%d paced interactive renders, one asked for a quarter slot late: %.3f s" % (FRAMES, late))
check(FRAMES / RATE * 0.98 <= late < FRAMES / RATE + 0.15 / RATE,
      "the slots keep their cadence after a late frame (%.3f s, expected %.2f s)" % (late, FRAMES / RATE))
still = seconds_for(lambda: Render(view))
log("%d still renders under the same limit: %.3f s" % (FRAMES, still))
check(still < FRAMES / RATE * 0.9, "still renders are not held (%.3f s)" % still)
display.MaximumInteractiveFrameRate = 0.0
free = seconds_for(lambda: view.SMProxy.InteractiveRender())
log("%d interactive renders without a limit: %.3f s" % (FRAMES, free))
check(free < FRAMES / RATE * 0.9, "0 lifts the limit (%.3f s)" % free)
nvtest.finish()
