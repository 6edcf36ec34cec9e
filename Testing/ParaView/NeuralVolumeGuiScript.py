"""Runs inside the ParaView GUI (paraview --script=..., started by TestNeuralVolumeGui.py): a still render returns
at once while the picture is still refining (path tracing below its target; a large grid decoded in the background
while a coarse one is shown), and the plugin's refresh driver renders the view again from the GUI's event loop until
it is final. Exits the GUI with 0 when every check passed, 1 otherwise (NV_GUI_REMOTE=1: the GUI is
connected to a pvserver; the information properties then describe the client, so the view's renders are counted)."""
import os
import sys
import time

sys.path.insert(0, os.environ["NV_TEST_DIR"])  # the GUI runs this script without __file__
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403


fail_on_exception = nvtest.fail_on_exception


REMOTE = os.environ.get("NV_GUI_REMOTE") == "1"
LABEL = "remote" if REMOTE else "builtin"
TARGET = 6
WAIT_MS = int(os.environ.get("NV_GUI_WAIT_MS", "20000"))
check, log = nvtest.check, nvtest.log


@fail_on_exception
def start():
    global view, display, first, renders
    if REMOTE:
        LoadPlugin(nvtest.plugin_path(), remote=True, ns=globals())
    nvtest.load_plugin(globals())
    import paraview.simple
    paraview.simple._DisableFirstRenderCameraReset()
    wavelet, nc = nvtest.wavelet_network(half=15, TrainingSteps=60)
    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = [300, 300]
    display = Show(nc, view)
    nvtest.set_camera(view, [55.0, -40.0, 75.0])
    check(display.Representation == "Neural Volume", "shown as Neural Volume")
    check(display.SMProxy.GetProperty("ProgressiveRefinement").GetElement(0) == 1,
          "the refresh driver made the GUI's view progressive")
    display.ShadingMode = "Path Tracing"
    display.TargetSamples = TARGET
    renders = []
    view.SMProxy.AddObserver("EndEvent", lambda caller, event: renders.append(1))
    Render(view)
    if not REMOTE:
        # (The CPU engine refines in a background thread: the render returned with the first, reduced image.)
        frames = nvtest.info(display, "LastAccumulatedFrames")
        check(frames < TARGET, "the still render returned before the target (%d of %d frames drawn)" % (frames, TARGET))
        check(nvtest.info(display, "WorkPending") == 1, "... with work pending (accumulation)")
    first = len(renders)
    # The view's first frame as the window shows it (a screenshot would render the final picture).
    nvtest.grab_window(view, os.path.join(nvtest.output_dir(), "gui_%s_first.png" % LABEL))


def check_screenshot_final():
    """Save Screenshot while the picture refines, at another size than the view's: the final picture of that size,
    not the frame refined so far nor one of the view's size (the built-in session reads the representation's figures;
    a client's describe the client, so the remote session only shows that the capture works)."""
    display.ShadingMode = "Path Tracing"
    display.TargetSamples = TARGET
    nvtest.set_camera(view, [60.0, 45.0, 70.0])
    Render(view)
    size = [200, 150]
    SaveScreenshot(os.path.join(nvtest.output_dir(), "gui_%s_screenshot.png" % LABEL), view, ImageResolution=size)
    if not REMOTE:
        paths, image = nvtest.info(display, "LastAccumulatedPaths"), list(nvtest.info(display, "LastImageSize"))
        log("Save Screenshot while refining: %s paths a pixel, image %s" % (paths, image))
        check(paths >= TARGET and image == size, "Save Screenshot rendered the final picture of its size (%s paths a "
              "pixel of %d, image %s)" % (paths, TARGET, image))


phase = ["path tracing"]
due = [0.0]


@fail_on_exception
def accumulated():
    """Phase 1 over: path tracing reached its target. Phase 2: a large decode grid, refined in the background."""
    global first, engine_renders
    check(len(renders) - first >= 2, "the driver rendered the view again (%d renders)" % (len(renders) - first))
    if not REMOTE:
        frames = nvtest.info(display, "LastAccumulatedFrames")
        check(frames >= TARGET, "the driver accumulated the target (%d of %d frames)" % (frames, TARGET))
        check(nvtest.info(display, "WorkPending") == 0, "nothing pending once the target is reached")
        check(nvtest.info(display, "EngineRenderCount") >= TARGET, "one engine render per refresh")
    log("path tracing: view renders after the first: %d" % (len(renders) - first))
    # The launcher compares the final picture with the first frame (this capture may render once more).
    nvtest.shot(view, os.path.join(nvtest.output_dir(), "gui_%s_final.png" % LABEL), [300, 300])

    display.ShadingMode = "Ray Marching"
    display.DecodeResolution = [160, 160, 160]  # above the CPU engine's progressive threshold
    engine_renders = None if REMOTE else nvtest.info(display, "EngineRenderCount")
    Render(view)
    first = len(renders)
    if not REMOTE:
        check(nvtest.info(display, "WorkPending") == 1, "a large decode: the still render shows a coarse grid at once")


@fail_on_exception
def decoded():
    check(len(renders) - first >= 1, "the driver rendered the refined grid (%d renders)" % (len(renders) - first))
    if not REMOTE:
        check(nvtest.info(display, "WorkPending") == 0, "the full grid is shown in the end")
        check(nvtest.info(display, "EngineRenderCount") >= engine_renders + 2, "coarse, then full grid")
    log("decode: view renders after the first: %d" % (len(renders) - first))
    check_screenshot_final()
    if not REMOTE:
        # A state saved by a script (ProgressiveRefinement off, a large decode grid) loaded in the GUI: the view
        # gets its interactor after the state set its representations, and its first still render must still show a
        # coarse grid at once instead of blocking the GUI for the full decode.
        display.SMProxy.GetProperty("ProgressiveRefinement").SetElement(0, 0)
        display.SMProxy.UpdateVTKObjects()
        display.DecodeResolution = [200, 200, 200]
        state = os.path.join(nvtest.output_dir(), "gui_%s_state.pvsm" % LABEL)
        SaveState(state)
        before = set(GetRenderViews())
        LoadState(state)
        loaded = [v for v in GetRenderViews() if v not in before]
        check(len(loaded) == 1, "the state brought its own view (%d new)" % len(loaded))
        if loaded:
            reps = [r for r in loaded[0].Representations if r.SMProxy.GetProperty("ProgressiveRefinement")]
            Render(loaded[0])
            check(len(reps) == 1 and reps[0].SMProxy.GetProperty("ProgressiveRefinement").GetElement(0) == 1,
                  "the loaded state's Neural Volume refines progressively in the GUI")
            check(len(reps) == 1 and nvtest.info(reps[0], "WorkPending") == 1,
                  "its first still render showed a coarse grid at once (the full decode pending)")
    nvtest.finish()
    nvtest._exit(0)


@fail_on_exception
def on_timer(caller, event):
    # TimerEvent observers see every timer of the interactor (the driver's too): act once ours is due. The calls
    # below process events: a nested timer event must not act again.
    if time.time() < due[0] - 1.0 or phase[0] == "busy":  # (Qt may fire a little early)
        return
    current, phase[0] = phase[0], "busy"
    if current == "path tracing":
        accumulated()
        phase[0] = "decode"
        due[0] = time.time() + 0.001 * WAIT_MS
        caller.CreateOneShotTimer(WAIT_MS)
    elif current == "decode":
        decoded()


start()
interactor = view.GetInteractor()
check(interactor is not None and interactor.IsA("QVTKInteractor"), "the GUI's view has a Qt interactor")
due[0] = time.time() + 0.001 * WAIT_MS
interactor.CreateOneShotTimer(WAIT_MS)
interactor.AddObserver("TimerEvent", on_timer)
