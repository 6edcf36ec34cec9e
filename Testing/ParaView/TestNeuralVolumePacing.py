"""Interactive renders are paced to MaximumInteractiveFrameRate (a display's rate, so that a network training beside
a turning view keeps the time between frames): interactive renders asked for back to back take at least one slot
each, the slots keep their cadence (a frame a little late does not delay the ones after it), still renders are never
held, and 0 lifts the limit; frames late because of the engine step the interactive image down
(AdaptiveInteractiveScale)."""
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
# whole run still takes 10 slots; pacing from each frame's start would add the quarter slot to every later one: 1.25
# slots more; half a slot of margin for a loaded machine).
late = seconds_for(lambda: view.SMProxy.InteractiveRender(), late_frame=5, late_by=1.25 / RATE)
log("%d paced interactive renders, one asked for a quarter slot late: %.3f s" % (FRAMES, late))
check(FRAMES / RATE * 0.98 <= late < FRAMES / RATE + 0.5 / RATE,
      "the slots keep their cadence after a late frame (%.3f s, expected %.2f s)" % (late, FRAMES / RATE))
still = seconds_for(lambda: Render(view))
log("%d still renders under the same limit: %.3f s" % (FRAMES, still))
check(still < FRAMES / RATE * 0.9, "still renders are not held (%.3f s)" % still)
display.MaximumInteractiveFrameRate = 0.0
free = seconds_for(lambda: view.SMProxy.InteractiveRender())
log("%d interactive renders without a limit: %.3f s" % (FRAMES, free))
check(free < FRAMES / RATE * 0.9, "0 lifts the limit (%.3f s)" % free)

# AdaptiveInteractiveScale (default on): at 1000 frames a second the CPU engine's frames (milliseconds each) are all
# late with the engine the cause: the third steps the interactive image down to 0.7 of InteractiveImageScale per axis,
# the sixth to 0.5, the floor; off, the image keeps InteractiveImageScale.
def interactive_sizes(frames):
    sizes = []
    view.SMProxy.InteractiveRender()
    for _ in range(frames):
        camera.Azimuth(3.0)
        view.SMProxy.InteractiveRender()
        display.SMProxy.UpdatePropertyInformation()
        sizes.append(tuple(display.GetPropertyValue("LastImageSize")))
    return sizes


check(display.AdaptiveInteractiveScale == 1, "the interactive image adapts by default")
display.MaximumInteractiveFrameRate = 1000.0
display.AdaptiveInteractiveScale = 0
fixed = interactive_sizes(8)
log("interactive image sizes, not adaptive: %r" % fixed)
check(all(s == (48, 48) for s in fixed), "not adaptive: InteractiveImageScale of the 96^2 view (%r)" % fixed)
display.AdaptiveInteractiveScale = 1
adapted = interactive_sizes(10)
log("interactive image sizes, adaptive, every frame late: %r" % adapted)
check(adapted[-1][0] == 24 and adapted[-1][1] == 24 and all(a[0] >= b[0] for a, b in zip(adapted, adapted[1:]))
      and any(s[0] == 34 for s in adapted), "late frames step the image down 48 -> 34 -> 24 (%r)" % adapted)
Render(view)
display.SMProxy.UpdatePropertyInformation()
check(tuple(display.GetPropertyValue("LastImageSize")) == (96, 96), "the still render is full size")
display.MaximumInteractiveFrameRate = 0.0
free_sizes = interactive_sizes(2)
check(free_sizes[-1] == (48, 48), "unpaced: full interactive detail again (%r)" % free_sizes)
nvtest.finish()
