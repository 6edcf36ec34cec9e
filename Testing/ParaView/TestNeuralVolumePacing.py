"""Interactive renders are paced to MaximumInteractiveFrameRate (a display's rate, so that a network training beside
a turning view keeps the time between frames): interactive renders asked for back to back take at least one slot
each, still renders are never held, and 0 lifts the limit."""
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


def seconds_for(render):
    view.SMProxy.InteractiveRender()  # the first frame starts the clock of the slots
    start = time.perf_counter()
    for _ in range(FRAMES):
        camera.Azimuth(3.0)
        render()
    return time.perf_counter() - start


display.MaximumInteractiveFrameRate = RATE
paced = seconds_for(lambda: view.SMProxy.InteractiveRender())
log("%d interactive renders at most %.0f a second: %.3f s" % (FRAMES, RATE, paced))
check(paced >= FRAMES / RATE * 0.98, "interactive renders wait for their slots (%.3f s >= %.2f s)"
      % (paced, FRAMES / RATE * 0.98))
still = seconds_for(lambda: Render(view))
log("%d still renders under the same limit: %.3f s" % (FRAMES, still))
check(still < FRAMES / RATE * 0.9, "still renders are not held (%.3f s)" % still)
display.MaximumInteractiveFrameRate = 0.0
free = seconds_for(lambda: view.SMProxy.InteractiveRender())
log("%d interactive renders without a limit: %.3f s" % (FRAMES, free))
check(free < FRAMES / RATE * 0.9, "0 lifts the limit (%.3f s)" % free)
nvtest.finish()
