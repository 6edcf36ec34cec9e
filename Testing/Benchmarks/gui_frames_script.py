"""The frame rate of the real ParaView GUI while the user turns the view (issue 24), run inside `paraview`
(gui_frames.sh starts it: paraview --dr --script=gui_frames_script.py). An xdotool process drags the mouse across the
render view as fast as it can (Testing/ParaView/GuiLatencyDriver.py); the render window's EndEvent counts the frames
the GUI drew meanwhile. Neural Compress trains in the background the whole time: its steps per second with the view
still (the live picture refreshed by the GUI's own timer) and during each drag give the training's share.

Phases, at each view size (layout preview mode, 1280x720; the view gets what the window holds, recorded): still view, then a drag with each Neural
Volume render path (Decode, Sample Streaming, In-Shader), then a drag over stock Volume of the original field, then
one over the empty view (nothing shown: the GUI's own ceiling on this display, xdotool's event rate included).
Environment: NV_PLUGIN, NV_TEST_OUTPUT (gui_frames.json goes there), NV_TEST_DIR (Testing/ParaView), NV_GUI_DEVICE
(CUDA or CPU), NV_GUI_SMALL=1 (a quick run: 32^3, small views, short drags), NV_DATA_DIR (the stent when present),
NV_HOST_PYTHON (the Python that runs the xdotool driver). Every figure is wall time in the GUI's process."""
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.environ["NV_TEST_DIR"])  # the GUI runs this script without __file__
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403

log = nvtest.log
OUT = nvtest.output_dir()
DRIVER = os.path.join(os.environ["NV_TEST_DIR"], "GuiLatencyDriver.py")
PYTHON = os.environ.get("NV_HOST_PYTHON", "/usr/bin/python3")
DEVICE = os.environ.get("NV_GUI_DEVICE", "CUDA")
SMALL = os.environ.get("NV_GUI_SMALL") == "1"
# (the GUI's main window holds a 1280x720 view at most on the device machine's Xvfb: larger previews are clipped)
SIZES = [(320, 180)] if SMALL else [(1280, 720)]
STILL_SECONDS = 1.0 if SMALL else 3.0
DRAG_STEPS = 20 if SMALL else 200
PATHS = ["Decode", "Sample Streaming", "In-Shader", "stock Volume", "empty view"]

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

frames, handled, ticks = [], [], []
state = {"phase": "starting", "since": time.time(), "driver": None, "offset": None, "size": 0, "path": 0,
         "results": {"data": data_name, "device": DEVICE, "sizes": {}}}


def on_frame(caller, event):
    frames.append(time.time())


def on_move(caller, event):
    x, y = caller.GetEventPosition()
    handled.append((time.time(), x, y))


def steps_trained():
    nc.SMProxy.UpdatePropertyInformation()
    return nc.GetPropertyValue("TotalStepsTrained")


def driver(args, name):
    path = os.path.join(OUT, "gui_frames_%s.txt" % name)
    return subprocess.Popen([PYTHON, DRIVER, "--log", path] + [str(a) for a in args]), path


def start_size():
    """A view of the next size (layout preview mode), then where it lies on the screen (it moves with its size)."""
    size = SIZES[state["size"]]
    layout.PreviewMode = list(size)
    Render(view)
    state.update(phase="calibrate", since=time.time(), driver=None, view=list(view.ViewSize))
    log("view %r (asked %r)" % (state["view"], size))


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
        neural.RenderPath = path
    Render(view)
    width, height = state["view"]
    ox, oy = state["offset"]
    x0, y0 = int(width * 0.2), int(height * 0.5)
    dx = max(1, int(width * 0.6 / DRAG_STEPS))
    proc, _ = driver(["drag", x0 + ox, (height - 1 - y0) + oy, DRAG_STEPS, dx, 0.0], "drag")
    state.update(phase="dragging", driver=proc, since=time.time(), steps=steps_trained(), frames=len(frames),
                 handled=len(handled))


def finish_drag(now):
    seconds = now - state["since"]
    drawn = frames[state["frames"]:]
    gaps = [b - a for a, b in zip(drawn, drawn[1:])]
    entry = {"seconds": round(seconds, 3), "frames": len(drawn), "fps": round(len(drawn) / seconds, 1),
             "frame_gap_median_ms": round(1000 * statistics.median(gaps), 2) if gaps else None,
             "events_handled": len(handled) - state["handled"]}
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
    if phase == "calibrate":
        if state["driver"] is None:
            proc, path = driver(["find"], "find")
            state.update(driver=proc, sent=path)
        elif state["driver"].poll() is not None and handled:
            t, x, y = handled[-1]
            with open(state["sent"]) as f:
                _, sx, sy = f.read().split()[-3:]
            height = view.ViewSize[1]
            state["offset"] = (int(sx) - x, int(sy) - (height - 1 - y))
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
    elif phase == "dragging" and state["driver"].poll() is not None:
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
interactor.AddObserver("MouseMoveEvent", on_move, 10.0)
interactor.AddObserver("TimerEvent", on_timer)
interactor.CreateRepeatingTimer(20)
start_size()
