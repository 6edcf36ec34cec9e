"""Runs inside the ParaView GUI (paraview --script=..., started by TestGuiLatency.py): how long the GUI takes to
handle input while Neural Compress trains on the CPU engine with its defaults and while the Neural Volume renders
by Sample Streaming and In-Shader. Real input: an xdotool process (GuiLatencyDriver.py) drags the mouse across the
render view, logging when it sent each event; the view's interactor logs when the GUI handled it. The latency of an
event is the time from its sending to the handling of it or of a later event (Qt merges pending moves). A 50 ms
timer also measures how long the event loop is ever kept from running. Writes gui_latency.json and exits the GUI
with 0 when every check passed, 1 otherwise."""
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.environ["NV_TEST_DIR"])  # the GUI runs this script without __file__
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403

check, log = nvtest.check, nvtest.log
fail_on_exception = nvtest.fail_on_exception
DRIVER = os.path.join(os.environ["NV_TEST_DIR"], "GuiLatencyDriver.py")
OUT = nvtest.output_dir()
MEDIAN_LIMIT, MAX_LIMIT = 0.2, 0.5

nvtest.load_plugin(globals(), scripted=False)
# A 128^3 field with the filter's defaults (background training on all cores, the automatic network size).
wavelet = Wavelet(WholeExtent=[-63, 64] * 3)
nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], Device="CPU", TimeBudget=0,
                    TrainingSteps=1000000)
view = GetActiveViewOrCreate("RenderView")
display = Show(nc, view)
view.ResetCamera()
Render(view)
interactor = view.GetInteractor()
check(interactor is not None and interactor.IsA("QVTKInteractor"), "the GUI's view has a Qt interactor")
size = view.ViewSize
log("view %d x %d" % (size[0], size[1]))

ticks, handled = [], []
state = {"phase": "calibrate", "since": time.time(), "driver": None, "results": {}, "offset": None}


def on_move(caller, event):
    x, y = caller.GetEventPosition()
    handled.append((time.time(), x, y))


def driver(args, log_name):
    path = os.path.join(OUT, log_name)
    proc = subprocess.Popen(["/usr/bin/python3", DRIVER, "--log", path] + [str(a) for a in args])
    return proc, path


def latencies(sent_path, since):
    """Seconds from each sent event to the handling of it or of a later one (events matched by x)."""
    sent = []
    with open(sent_path) as f:
        for line in f:
            t, x, y = line.split()
            sent.append((float(t), int(x), int(y)))
    ox, oy = state["offset"]
    got = [(t, x + ox) for (t, x, y) in handled if t >= since]
    result = []
    for index, (t_sent, x_sent, _) in enumerate(sent):
        later = [t for (t, x) in got if t >= t_sent and x >= x_sent]  # x grows with the index
        result.append(min(later) - t_sent if later else float("inf"))
    return result


def gaps(since, until):
    times = [t for t in ticks if since <= t <= until]
    return [b - a for a, b in zip(times, times[1:])]


def summarise(name, lat, gap_list):
    finite = [v for v in lat if v != float("inf")]
    if len(finite) < len(lat):
        log("%s: events never handled: %r" % (name, [k for k, v in enumerate(lat) if v == float("inf")]))
    entry = {"events": len(lat), "handled": len(finite),
             "median_s": statistics.median(lat) if lat else float("inf"),
             "max_s": max(lat) if lat else float("inf"),
             "timer_gap_max_s": max(gap_list) if gap_list else float("inf"),
             "timer_gap_median_s": statistics.median(gap_list) if gap_list else float("inf")}
    state["results"][name] = entry
    log("%s: %d events, input latency median %.3f s, max %.3f s; 50 ms timer gaps median %.3f s, max %.3f s"
        % (name, len(lat), entry["median_s"], entry["max_s"], entry["timer_gap_median_s"], entry["timer_gap_max_s"]))
    check(len(finite) == len(lat) and len(lat) >= 20, "%s: every event handled (%d of %d)" % (name, len(finite), len(lat)))
    check(entry["median_s"] <= MEDIAN_LIMIT, "%s: median input latency %.3f s <= %.1f s"
          % (name, entry["median_s"], MEDIAN_LIMIT))
    check(entry["max_s"] <= MAX_LIMIT, "%s: largest input latency %.3f s <= %.1f s" % (name, entry["max_s"], MAX_LIMIT))


def start_drag(name):
    # A drag along a horizontal line through the view's centre: it rotates the camera (interactive renders).
    x0, y0 = int(size[0] * 0.25), int(size[1] * 0.5)
    ox, oy = state["offset"]
    proc, path = driver(["drag", x0 + ox, (size[1] - 1 - y0) + oy, 60, 6, 0.12], "gui_latency_%s.txt" % name)
    state.update(driver=proc, sent=path, since=time.time(), name=name)


WATCH_SECONDS = 8.0


def steps_of(text):
    import re
    match = re.search(r": (\d+)", text)
    return int(match.group(1)) if match else 0


def status():
    nc.SMProxy.UpdatePropertyInformation()
    return nc.GetPropertyValue("TrainingStatus") or ""


@fail_on_exception
def on_timer(caller, event):
    now = time.time()
    ticks.append(now)
    phase = state["phase"]
    if phase == "busy":
        return
    if phase == "calibrate":
        # Where the view is on the screen: a move to a window point, and where the interactor saw it.
        if state["driver"] is None:
            proc, path = driver(["find"], "gui_latency_find.txt")
            state.update(driver=proc, sent=path)
        elif state["driver"].poll() is not None and handled:
            t, x, y = handled[-1]
            with open(state["sent"]) as f:
                _, sx, sy = f.read().split()[-3:]
            # screen x = view x + ox; screen y = (height - 1 - view y) + oy
            state["offset"] = (int(sx) - x, int(sy) - (size[1] - 1 - y))
            log("view origin on the screen: %r (status %r)" % (state["offset"], status()))
            state["driver"] = None
            state["phase"] = "train-wait"
            state["since"] = now
        elif now - state["since"] > 20.0:
            check(False, "the mouse reached the render view")
            nvtest.finish()
            nvtest._exit(1)
    elif phase == "train-wait" and (status().startswith("Training") or now - state["since"] > 30.0):
        # The view is still for a while: how fast training goes beside the live picture.
        state.update(phase="watching", since=now, steps=steps_of(status()))
    elif phase == "watching" and now - state["since"] > WATCH_SECONDS:
        steps = steps_of(status()) - state["steps"]
        state["results"]["watching"] = {"steps_per_s": steps / (now - state["since"])}
        log("training beside the still view: %.2f steps/s (%r)" % (steps / (now - state["since"]), status()))
        start_drag("training")
        state["phase"] = "dragging"
    elif phase == "dragging" and state["driver"].poll() is not None:
        state["phase"], state["ended"] = "settling", now  # the last events may still be on their way
    elif phase == "settling" and now - state["ended"] > MAX_LIMIT + 0.1:
        state["phase"] = "dragging"
        name = state["name"]
        summarise(name, latencies(state["sent"], state["since"]), gaps(state["since"], now))
        if name == "training":
            log("after the drag: %r" % status())
            nc.StopTraining()
            next_path = "Sample Streaming"
        elif name == "Sample Streaming":
            next_path = "In-Shader"
        elif name == "In-Shader":
            apply_large_table()
            start_drag("large table")
            return
        else:
            next_path = None
        if next_path is None:
            with open(os.path.join(OUT, "gui_latency.json"), "w") as f:
                json.dump(state["results"], f, indent=1)
            nvtest.shot(view, os.path.join(OUT, "gui_latency_last.png"), size)
            nvtest.finish()
            nvtest._exit(0)
        display.RenderPath = next_path
        Render(view)
        start_drag(next_path)


def apply_large_table():
    # A user's Apply of a 2^21-entry table (16 levels x 2 features: 64 M parameters): the network is made, initialised
    # and serialized in the training's threads; the Apply and every live refresh after it keep the GUI answering.
    display.RenderPath = "Decode"
    nc.Log2TableSize = 21
    started = time.time()
    nc.UpdatePipeline()
    seconds = time.time() - started
    state["results"]["large table apply"] = {"apply_s": seconds, "status": status()}
    log("Apply with a 2^21 table: %.3f s in the GUI thread (%r)" % (seconds, status()))
    check(seconds <= 0.1, "the Apply of a 2^21-entry table returns within 0.1 s (%.3f s)" % seconds)
    Render(view)


interactor.AddObserver("MouseMoveEvent", on_move, 10.0)
interactor.AddObserver("LeftButtonReleaseEvent", on_move, 10.0)  # Qt may merge the last moves into the release
interactor.AddObserver("TimerEvent", on_timer)
interactor.CreateRepeatingTimer(50)
