"""Runs inside the ParaView GUI connected to a 2-rank pvserver (paraview --server-url=... --script=..., started by
TestNeuralCompressParallelServer.py): a Neural Compress of the Wavelet (a network per rank) shown as Neural Volume
with shadows. Checks that the GUI keeps its still renders blocking there (a parallel server composites its ranks'
pictures in every render, so progressive pictures would each stand at their own rank's stage: the view showed
nothing, or a cut picture), that the picture the view's window holds covers the volume like a screenshot of the
same size does and matches it, and that the colour legend is drawn whole. Exits the GUI with 0 when every check
passed, 1 otherwise."""
import os
import sys

sys.path.insert(0, os.environ["NV_TEST_DIR"])  # the GUI runs this script without __file__
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402

check, log = nvtest.check, nvtest.log
BACKGROUND = [0.32, 0.34, 0.43]
SAME_PICTURE_DB = 50.0  # the same render: identical here (a progressive one had a seam along the pieces: 44.6 dB)


def covered(pixels):
    return np.abs(pixels - np.array(BACKGROUND) * 255.0).max(axis=2) > 8.0


@nvtest.fail_on_exception
def run():
    # The GUI's Python output goes to its own window: the checks' lines go to a file the launcher prints.
    sys.stderr = open(os.path.join(nvtest.output_dir(), "gui_parallel.log"), "w", buffering=1)
    LoadPlugin(nvtest.plugin_path(), remote=True, ns=globals())
    nvtest.load_plugin(globals())
    check(servermanager.ActiveConnection.GetNumberOfDataPartitions() == 2, "the GUI is connected to 2 ranks")
    wavelet = Wavelet(WholeExtent=[-32, 31, -32, 31, -32, 31])
    nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], Device="CPU", Seed=7, Deterministic=1,
                        TrainingSteps=100, BatchSize=8192, Levels=8, Log2TableSize=14, Threads=1, PSNRInterval=0,
                        TrainInBackground=0)
    view = GetActiveViewOrCreate("RenderView")
    view.Background = BACKGROUND
    view.OrientationAxesVisibility = 0
    display = Show(nc, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "RTData"))
    display.SetScalarBarVisibility(view, True)
    display.ShadingMode = "Ray Marching + Shadows"
    nvtest.set_camera(view, [120.0, -90.0, 110.0], focal=(-0.5, -0.5, -0.5))
    Render(view)
    out = nvtest.output_dir()
    size = list(view.ViewSize)
    window = nvtest.grab_window(view, os.path.join(out, "gui_parallel_window.png"))
    shot = os.path.join(out, "gui_parallel_screenshot.png")
    SaveScreenshot(shot, view, ImageResolution=size)
    screenshot = nvtest.read_png(shot)
    log("view %s: the window's picture covers %.1f%% of the view, the screenshot %.1f%%"
        % (size, 100 * covered(window).mean(), 100 * covered(screenshot).mean()))
    check(window.shape == screenshot.shape and covered(window).mean() > 0.1,
          "the view's window shows the volume (%.1f%% covered)" % (100 * covered(window).mean()))
    if window.shape == screenshot.shape:
        db = nvtest.image_psnr(window, screenshot)
        log("window vs screenshot: %.2f dB" % db)
        check(db >= SAME_PICTURE_DB, "the window holds the screenshot's picture (%.2f dB)" % db)
        # The colour legend (bottom right) drawn whole: its lowest rows are not the background in the window alone.
        rows = window.shape[0]
        legend_window = covered(window[int(0.75 * rows):, int(0.8 * window.shape[1]):]).mean()
        legend_shot = covered(screenshot[int(0.75 * rows):, int(0.8 * window.shape[1]):]).mean()
        check(legend_window >= 0.5 * legend_shot, "the legend's lower part is drawn in the window (%.3f, screenshot "
              "%.3f)" % (legend_window, legend_shot))
    progressive = display.SMProxy.GetProperty("ProgressiveRefinement").GetElement(0)
    check(progressive == 0, "still renders stay blocking on a parallel server (ProgressiveRefinement %d)" % progressive)
    sys.stdout.flush()
    nvtest.finish()
    nvtest._exit(0)


run()
