"""The frame rate of the real ParaView GUI while the user turns the view (issue 24), run inside `paraview`
(gui_frames.sh starts it: paraview --dr --script=gui_frames_script.py). An xdotool process presses the mouse in the
render view and moves it every 4 ms from one process (Testing/ParaView/GuiLatencyDriver.py `stream`: input always
waiting, so the GUI's own drawing sets the rate); the render window's StartEvent/EndEvent time every frame drawn between
the press and the release the GUI handled. Neural Compress trains in the background the whole time: its steps per
second with the view still (the live picture refreshed by the GUI's own timer) and during each drag give the training's
share.

Per drag: frames per second over the drag (frames between the handled press and release, over that time), the median
and 90th percentile gap between frames, the median time inside the render window's Render (ParaView's frame, the
mapper's paced wait included) and outside it (Qt, the event loop, the X server), and the mapper's own timings of the
last frame. Phases, at each view size (layout preview mode, 1280x720; the view gets what the window holds,
recorded): still view, then a drag with each Neural Volume render path (Decode, Sample Streaming, In-Shader), the
same paths with the representation's frame pacing off (MaximumInteractiveFrameRate 0), a drag over stock Volume of
the original field, then one over the empty view (nothing shown: the GUI's own ceiling on this display).
Environment: NV_PLUGIN, NV_TEST_OUTPUT (gui_frames.json goes there), NV_TEST_DIR (Testing/ParaView), NV_GUI_DEVICE
(CUDA or CPU), NV_GUI_SMALL=1 (a quick run: 32^3, small views, short drags), NV_DATA_DIR (the stent when present),
NV_HOST_PYTHON (the Python that runs the xdotool driver), NV_GUI_SIZES (e.g. 1280x720,1920x1080), NV_GUI_SAMPLE=1 (thread_sampler.py on the GUI thread
during each drag: the share of time it runs and the system calls it waits in), NV_GUI_FULLSCREEN=1 (View > Full Screen
(layout), F11, its window sized so the view is each size: no panels drawn around the view; the screen must hold the
view plus 4 pixels). Every figure is wall time in the GUI's process."""
import json
import os
import signal
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.environ["NV_TEST_DIR"])  # the GUI runs this script without __file__
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403

def log(msg):
    """To the process's own stderr (gui_frames.log): through ParaView's output window each message would pop its
    dialog up over the view."""
    sys.__stderr__.write(str(msg) + "\n")
    sys.__stderr__.flush()
OUT = nvtest.output_dir()
DRIVER = os.path.join(os.environ["NV_TEST_DIR"], "GuiLatencyDriver.py")
SAMPLER = os.path.join(os.path.dirname(os.environ["NV_TEST_DIR"]), "Benchmarks", "thread_sampler.py")
SAMPLE = os.environ.get("NV_GUI_SAMPLE") == "1"  # sample the GUI thread's state during each drag
PERF = os.environ.get("NV_GUI_PERF")  # a perf binary: profile the GUI thread during each drag (perf record -t)
PYTHON = os.environ.get("NV_HOST_PYTHON", "/usr/bin/python3")
DEVICE = os.environ.get("NV_GUI_DEVICE", "CUDA")
SMALL = os.environ.get("NV_GUI_SMALL") == "1"
FULLSCREEN = os.environ.get("NV_GUI_FULLSCREEN") == "1"  # the layout full screen (F11), its window sized to the view
# (a 1920 x 1080 preview needs a main window of about 2400 x 1500: gui_frames.sh's NV_GUI_GEOMETRY)
SIZES = [(320, 180)] if SMALL else [(1280, 720), (1920, 1080)]
if os.environ.get("NV_GUI_SIZES"):  # e.g. "1280x720,1920x1080"
    SIZES = [tuple(int(v) for v in size.split("x")) for size in os.environ["NV_GUI_SIZES"].split(",")]
STILL_SECONDS = 1.0 if SMALL else 3.0
DRAG_STEPS = 60 if SMALL else 600
MOVE_PERIOD = 0.004
NEURAL = ["Decode", "Sample Streaming", "In-Shader"]
PATHS = NEURAL + [p + " (unpaced)" for p in NEURAL] + ["stock Volume", "empty view"]

nvtest.load_plugin(globals(), scripted=False)
stent = os.path.join(os.environ.get("NV_DATA_DIR", ""), "stent", "stent_128x128x256_int16.nhdr")
if not SMALL and os.path.exists(stent):
    source, array, data_name = NrrdReader(FileName=stent), "ImageFile", "stent"
else:
    n = 32 if SMALL else 256
    source, array, data_name = Wavelet(WholeExtent=[0, n - 1] * 3), "RTData", "wavelet%d" % n
nc = NeuralCompress(Input=source, SelectInputScalars=["POINTS", array], Device=DEVICE, TimeBudget=0,
                    TrainingSteps=10 ** 8, Log2TableSize=19)
view = GetActiveViewOrCreate("RenderView")
view.OrientationAxesVisibility = 0
layout = GetLayout(view)
neural = Show(nc, view)
ColorBy(neural, ("POINTS", array))
neural.SetRepresentationType("Neural Volume")
neural.SetScalarBarVisibility(view, False)
stock = Show(source, view)
ColorBy(stock, ("POINTS", array))
stock.SetRepresentationType("Volume")
stock.SetScalarBarVisibility(view, False)
Hide(source, view)
view.ResetCamera()
Render(view)
interactor = view.GetInteractor()
window = view.GetRenderWindow()

frames, starts, handled, ticks, buttons = [], [], [], [], []
state = {"phase": "starting", "since": time.time(), "driver": None, "offset": None, "size": 0, "path": 0,
         "results": {"data": data_name, "device": DEVICE, "fullscreen": FULLSCREEN, "sizes": {}}}


def on_frame(caller, event):
    frames.append(time.time())


def on_frame_start(caller, event):
    starts.append(time.time())


def on_button(caller, event):
    buttons.append((time.time(), event))


def on_move(caller, event):
    x, y = caller.GetEventPosition()
    handled.append((time.time(), x, y))


def steps_trained():
    nc.SMProxy.UpdatePropertyInformation()
    return nc.GetPropertyValue("TotalStepsTrained")


def driver(args, name):
    path = os.path.join(OUT, "gui_frames_%s.txt" % name)
    return subprocess.Popen([PYTHON, DRIVER, "--log", path] + [str(a) for a in args]), path


def xdotool(*args):
    return subprocess.run(["xdotool"] + [str(a) for a in args], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                          text=True, timeout=10).stdout.split()


def start_size():
    """A view of the next size (layout preview mode, or the full-screen layout's window sized to it), then where it
    lies on the screen (it moves with its size)."""
    size = SIZES[state["size"]]
    if FULLSCREEN:
        if "fullscreen_window" not in state:  # F11 (View > Full Screen (layout)) in the main window, once
            state["windows_before"] = set(xdotool("search", "--class", "ParaView"))
            main = xdotool("search", "--onlyvisible", "--name", "ParaView 5")
            xdotool("mousemove", 400, 300)
            if main:
                xdotool("windowfocus", "--sync", main[0])
            xdotool("key", "F11")
        state.update(phase="fullscreen", since=time.time(), driver=None, border=(4, 4), resized_at=None)
        return
    layout.PreviewMode = list(size)
    Render(view)
    state.update(phase="calibrate", since=time.time(), driver=None, view=list(view.ViewSize))
    log("asked for a %r view" % (size,))


def fit_fullscreen_window(now):
    """The full-screen layout's own top-level window (without a window manager Qt cannot make it full screen) sized
    so that the view inside it is the size asked for; then calibration. False while it is not there yet."""
    size = SIZES[state["size"]]
    if "fullscreen_window" not in state:
        new = [w for w in xdotool("search", "--class", "ParaView") if w not in state["windows_before"]]
        if not new:
            return False
        state["fullscreen_window"] = new[-1]
        log("full-screen layout window %s (new windows %r)" % (new[-1], new))
    if list(view.ViewSize) == list(size):
        state.update(phase="calibrate", since=now, driver=None, view=list(view.ViewSize))
        log("full-screen layout: a %r view in a window %r larger" % (size, state["border"]))
        return True
    if state.get("resized_at") is None:
        xdotool("windowsize", state["fullscreen_window"], size[0] + state["border"][0], size[1] + state["border"][1])
        state["resized_at"] = now
    elif now - state["resized_at"] > 2.0:  # settled at another size: the window's border is not the one assumed
        shell = dict(line.split("=") for line in xdotool("getwindowgeometry", "--shell", state["fullscreen_window"]))
        state["border"] = (int(shell["WIDTH"]) - view.ViewSize[0], int(shell["HEIGHT"]) - view.ViewSize[1])
        state["resized_at"] = None
    return False


def start_still():
    state.update(phase="still", since=time.time(), steps=steps_trained())


def start_drag():
    path = PATHS[state["path"]]
    if path == "stock Volume":
        Hide(nc, view)
        Show(source, view)
    elif path == "empty view":
        Hide(nc, view)
        Hide(source, view)
    else:
        neural.RenderPath = path.replace(" (unpaced)", "")
        neural.MaximumInteractiveFrameRate = 0 if "unpaced" in path else 60
    Render(view)
    width, height = state["view"]
    ox, oy = state["offset"]
    x0, y0 = int(width * 0.2), int(height * 0.5)
    dx = max(1, int(width * 0.6 / DRAG_STEPS))
    proc, _ = driver(["stream", x0 + ox, (height - 1 - y0) + oy, DRAG_STEPS, dx, MOVE_PERIOD], "drag")
    if SAMPLE:
        state["sampler"] = subprocess.Popen([PYTHON, SAMPLER, str(os.getpid()), str(os.getpid()), sample_path()])
    if PERF:
        state["perf"] = subprocess.Popen([PERF, "record", "-F", "1999", "-t", str(os.getpid()), "-o",
                                          sample_path().replace(".json", ".perf")], stdout=subprocess.DEVNULL,
                                         stderr=subprocess.DEVNULL)
    state.update(phase="dragging", driver=proc, since=time.time(), steps=steps_trained(), frames=len(frames),
                 handled=len(handled), buttons=len(buttons))


def percentile(values, q):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else None


def drag_span(now):
    """(press, release) of this drag as the GUI handled them; release None while it is still in the queue."""
    events = buttons[state["buttons"]:]
    press = next((t for t, e in events if e == "LeftButtonPressEvent"), None)
    release = next((t for t, e in events if e == "LeftButtonReleaseEvent" and press is not None and t > press), None)
    return (press if press is not None else state["since"]), release


def drag_figures(now):
    """Frames drawn between the press and the release the GUI handled (the still render after it excluded)."""
    press, release = drag_span(now)
    release = release if release is not None else now
    ends = [t for t in frames[state["frames"]:] if press < t <= release]
    begins = [t for t in starts if press < t <= release]
    inside = [b - a for a, b in zip(begins, ends) if b >= a]
    gaps = [b - a for a, b in zip(ends, ends[1:])]
    outside = [b - a for a, b in zip(ends, begins[1:]) if b >= a]
    ms = lambda v: round(1000 * v, 2) if v is not None else None  # noqa: E731
    seconds = release - press
    return {"seconds": round(seconds, 3), "frames": len(ends),
            "fps": round((len(ends) - 1) / (ends[-1] - ends[0]), 1) if len(ends) > 1 else 0.0,
            "frame_gap_median_ms": ms(statistics.median(gaps)) if gaps else None,
            "frame_gap_p90_ms": ms(percentile(gaps, 0.9)),
            "inside_render_median_ms": ms(statistics.median(inside)) if inside else None,
            "outside_render_median_ms": ms(statistics.median(outside)) if outside else None,
            "events_handled": len([h for h in handled[state["handled"]:] if press < h[0] <= release])}


def sample_path():
    return os.path.join(OUT, "gui_sample_%d_%d.json" % (state["size"], state["path"]))


def perf_report(path):
    """The GUI thread's samples by library (top 12), then by library and function (top 15): perf report."""
    def report(sort):
        text = subprocess.run([PERF, "report", "--stdio", "--sort", sort, "-i", path], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True, timeout=120).stdout
        with open("%s.%s.txt" % (path, sort.replace(",", "_")), "w") as f:
            f.write(text)
        return [line.strip() for line in text.splitlines() if line.strip() and not line.startswith("#")]
    return report("dso")[:12] + report("dso,sym")[:15]


def finish_drag(now):
    seconds = now - state["since"]
    entry = drag_figures(now)
    if SAMPLE and state.get("sampler"):
        state["sampler"].terminate()
        state["sampler"].wait(timeout=10)
        with open(sample_path()) as f:
            entry["main_thread"] = json.load(f)
    if PERF and state.get("perf"):
        state["perf"].send_signal(signal.SIGINT)
        state["perf"].wait(timeout=30)
        entry["perf_report"] = perf_report(sample_path().replace(".json", ".perf"))
    size_entry = state["results"]["sizes"][str(SIZES[state["size"]])]
    if PATHS[state["path"]] not in ("stock Volume", "empty view"):
        # (with stock Volume shown the filter's output is hidden: nothing reports the training's steps)
        entry["steps_per_s"] = round((steps_trained() - state["steps"]) / seconds, 1)
        alone = size_entry["still"]["steps_per_s"]
        entry["training_share"] = round(entry["steps_per_s"] / alone, 3) if alone > 0 else None
        neural.SMProxy.UpdatePropertyInformation()
        entry["last_frame_timings"] = list(neural.GetPropertyValue("LastFrameTimings"))
        entry["display_path"] = neural.GetPropertyValue("LastDisplayPath")
    else:
        Hide(source, view)
        Show(nc, view)
        Render(view)
    if entry["events_handled"] == 0:
        entry = {"error": "the drag missed the view (no move handled between press and release)"}
    size_entry[PATHS[state["path"]]] = entry
    log("%r %s: %r" % (SIZES[state["size"]], PATHS[state["path"]], entry))


def write_and_exit():
    with open(os.path.join(OUT, "gui_frames.json"), "w") as f:
        json.dump(state["results"], f, indent=1)
    nc.StopTraining()
    nvtest._exit(0)


@nvtest.fail_on_exception
def on_timer(caller, event):
    now = time.time()
    ticks.append(now)
    phase = state["phase"]
    if phase == "fullscreen":
        if not fit_fullscreen_window(now) and now - state["since"] > 30.0:
            log("the full-screen layout never reached %r (view %r)" % (SIZES[state["size"]], list(view.ViewSize)))
            nvtest._exit(1)
    elif phase == "calibrate":
        if state["driver"] is None:
            proc, path = driver(["scan"], "find")
            state.update(driver=proc, sent=path, handled=len(handled))
        elif state["driver"].poll() is not None and len(handled) > state["handled"]:
            t, x, y = handled[state["handled"]]  # the first move the view handled, and the last one sent before it
            with open(state["sent"]) as f:
                sent = [line.split() for line in f if line.strip()]
            _, sx, sy = [row for row in sent if float(row[0]) <= t][-1]
            state["view"] = list(view.ViewSize)  # (the layout has settled by now)
            height = view.ViewSize[1]
            state["offset"] = (int(sx) - x, int(sy) - (height - 1 - y))
            log("calibration: the %r view handled (%d, %d) after the move to (%s, %s)" % (state["view"], x, y, sx, sy))
            state["driver"] = None
            start_still()
        elif now - state["since"] > 30.0:
            log("the mouse never reached the render view")
            nvtest._exit(1)
    elif phase == "still" and now - state["since"] > STILL_SECONDS:
        seconds = now - state["since"]
        still = {"steps_per_s": round((steps_trained() - state["steps"]) / seconds, 1),
                 "frames_per_s": round(len([t for t in frames if t >= state["since"]]) / seconds, 2)}
        state["results"]["sizes"][str(SIZES[state["size"]])] = {"view": state["view"], "still": still}
        log("%r still view: %r" % (SIZES[state["size"]], still))
        state["path"] = 0
        start_drag()
    elif phase == "dragging" and state["driver"].poll() is not None and (
            drag_span(now)[1] is not None or now - state["since"] > 60.0):
        finish_drag(now)
        state["path"] += 1
        if state["path"] < len(PATHS):
            start_drag()
            return
        state["size"] += 1
        if state["size"] < len(SIZES):
            start_size()
        else:
            write_and_exit()


window.AddObserver("EndEvent", on_frame)
window.AddObserver("StartEvent", on_frame_start)
interactor.AddObserver("LeftButtonPressEvent", on_button, 10.0)
interactor.AddObserver("LeftButtonReleaseEvent", on_button, 10.0)
interactor.AddObserver("MouseMoveEvent", on_move, 10.0)
interactor.AddObserver("TimerEvent", on_timer)
interactor.CreateRepeatingTimer(20)
start_size()
