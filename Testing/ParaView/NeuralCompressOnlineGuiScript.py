"""Runs inside the ParaView GUI (paraview --script=..., started by TestNeuralVolumeGui.py): Neural Compress with its
default background training. Apply returns at once; without any script call, ParaView's live-source timer
re-executes the filter (its TrainingStatus advances) and re-renders the view while the network learns; the event
loop keeps running (no gap of seconds between timer callbacks); the Stop button's command ends the training and the
panel's status says so. Exits the GUI with 0 when every check passed, 1 otherwise."""
import os
import re
import sys
import time

sys.path.insert(0, os.environ["NV_TEST_DIR"])  # the GUI runs this script without __file__
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403

check, log = nvtest.check, nvtest.log


fail_on_exception = nvtest.fail_on_exception


def status():
    nc.SMProxy.UpdatePropertyInformation()
    text = nc.GetPropertyValue("TrainingStatus")
    match = re.match(r"(\w+): (\d+)", text or "")
    return (match.group(1), int(match.group(2))) if match else (text, -1)


nvtest.load_plugin(globals(), scripted=False)
wavelet = Wavelet(WholeExtent=[-47, 48] * 3)
nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=1000000, TimeBudget=0,
                    BatchSize=8192, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Threads=2,
                    PSNRInterval=50)
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [300, 300]
start = time.time()
display = Show(nc, view)
view.ResetCamera()
Render(view)
log("Apply + Show + first render: %.2f s, status %r" % (time.time() - start, status()))
renders = []
view.SMProxy.AddObserver("EndEvent", lambda caller, event: renders.append(time.time()))
ticks = []
samples = []
phase = ["watch"]


@fail_on_exception
def on_timer(caller, event):
    now = time.time()
    ticks.append(now)
    if phase[0] == "busy":
        return
    if phase[0] == "watch" and now - start > 2.0 and not samples:
        samples.append((now, status(), len(renders)))
    elif phase[0] == "watch" and samples and now - samples[0][0] > 4.0:
        phase[0] = "busy"
        (t0, (state0, steps0), renders0) = samples[0]
        state1, steps1 = status()
        log("live: %s %d steps -> %s %d steps in %.1f s, %d view renders meanwhile"
            % (state0, steps0, state1, steps1, now - t0, len(renders) - renders0))
        check(state1 == "Training" and steps1 > steps0,
              "the live-source timer re-executes the filter while it trains (%d -> %d steps)" % (steps0, steps1))
        check(len(renders) - renders0 >= 3, "the view is rendered again as the network learns")
        gaps = [b - a for a, b in zip(ticks, ticks[1:])]
        log("largest gap between 100 ms timer callbacks: %.3f s" % max(gaps))
        check(max(gaps) < 2.0, "the event loop keeps running while training (largest gap %.2f s)" % max(gaps))
        nvtest.shot(view, os.path.join(nvtest.output_dir(), "gui_online_training.png"), [300, 300])
        nc.StopTraining()  # what the panel's Stop Training button invokes
        samples.append((time.time(), None, len(renders)))
        phase[0] = "stopping"
    elif phase[0] == "stopping" and (status()[0] in ("Finishing", "Stopped") or now - samples[1][0] > 5.0):
        phase[0] = "busy"
        state, steps = status()
        log("Stop Training: the panel's status says %s %.3f s after the click (next timer callback), at %d steps"
            % (state, now - samples[1][0], steps))
        check(state in ("Finishing", "Stopped"), "the panel's status shows the stop without a script update (%s)"
              % state)
        samples.append((time.time(), (state, steps), len(renders)))
        phase[0] = "stopped"
    elif phase[0] == "stopped" and (status()[0] == "Stopped" or now - samples[2][0] > 20.0):
        phase[0] = "busy"
        state, steps = status()
        log("then: %s at %d steps" % (state, steps))
        check(state == "Stopped" and steps <= samples[2][1][1] + 1, "stopped, measured, no more steps (%s, %d)"
              % (state, steps))
        nvtest.finish()
        nvtest._exit(0)


interactor = view.GetInteractor()
check(interactor is not None and interactor.IsA("QVTKInteractor"), "the GUI's view has a Qt interactor")
interactor.AddObserver("TimerEvent", on_timer)
interactor.CreateRepeatingTimer(100)
