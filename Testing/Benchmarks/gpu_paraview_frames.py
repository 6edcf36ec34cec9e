"""The frame as ParaView shows it, on the GPU machine (issue 24): pvbatch Render() times of every Neural Volume
ray-marching path against stock Volume of the original field and an empty view, at 1280x720 and 1920x1080, with
CUDA-OpenGL interop on and off, and where each Neural Volume frame's time goes (LastFrameTimings: depth read, engine
call, host copy, upload or interop copy, draw, the mapper's whole draw). Then training beside a rotating view (steps
per second against the same training alone) and a path-tracing still render against one pass.

    pvbatch --force-offscreen-rendering gpu_paraview_frames.py PLUGIN OUT_JSON [--data NHDR] [--n 256]
            [--device CUDA] [--small]        (--device CPU --small --n 32: a quick run of the script itself)

Without --data the field is ParaView's Wavelet at n^3; with it, a raw volume read by ParaView's NRRD reader (the
stent). Every figure is wall time in the script's thread (the frame as ParaView shows it) unless named engine."""
import argparse
import json
import math
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "ParaView"))
import nvtest  # noqa: E402  (read_png, region_psnr, shot)

from paraview.simple import *  # noqa: F401,F403,E402
from paraview import servermanager
import paraview.simple

SIZES = [(1280, 720), (1920, 1080)]
OUT_DIR = "."  # the path-tracing pictures go beside the JSON file
DEVICE = "CUDA"
PATHS = ["Decode", "Sample Streaming", "In-Shader"]
ORBIT = 30


def orbit_ms(view, render, display=None):
    """Median ms of a Render() while the camera turns 3 degrees a frame; with a display, the medians of its
    LastFrameTimings too."""
    camera = view.GetActiveCamera()
    render(view)
    seconds, parts = [], []
    for _ in range(ORBIT):
        camera.Azimuth(3.0)
        started = time.perf_counter()
        render(view)
        seconds.append(time.perf_counter() - started)
        if display is not None:
            display.SMProxy.UpdatePropertyInformation()
            parts.append(list(display.GetPropertyValue("LastFrameTimings")))
    result = {"render_ms": round(1000 * statistics.median(seconds), 3)}
    if parts:
        names = ["depth_ms", "engine_call_ms", "host_copy_ms", "upload_ms", "draw_ms", "mapper_ms", "engine_setup_ms",
                 "engine_gpu_ms"]
        for k, name in enumerate(names):
            result[name] = round(statistics.median(p[k] for p in parts), 3)
        display.SMProxy.UpdatePropertyInformation()
        result["engine_kernel_ms"] = round(display.GetPropertyValue("LastRenderMilliseconds"), 3)
        result["display_path"] = display.GetPropertyValue("LastDisplayPath")
    return result


def still(view):
    Render(view)


def interactive(view):
    view.SMProxy.InteractiveRender()


def frames(source, array, nc, size):
    view = CreateRenderView()
    view.ViewSize = list(size)
    view.OrientationAxesVisibility = 0
    out = {"empty_ms": orbit_ms(view, still)["render_ms"]}
    stock = Show(source, view)
    ColorBy(stock, ("POINTS", array))
    stock.SetRepresentationType("Volume")
    stock.SetScalarBarVisibility(view, False)
    view.ResetCamera()
    out["stock_volume"] = orbit_ms(view, still)
    Hide(source, view)
    neural = Show(nc, view)
    ColorBy(neural, ("POINTS", array))
    neural.SetRepresentationType("Neural Volume")
    neural.SetScalarBarVisibility(view, False)  # as for stock (a colour legend costs ParaView ~1 ms of text a frame)
    neural.MaximumInteractiveFrameRate = 0  # the frame's own cost here: interactive renders not paced
    for path in PATHS:
        neural.RenderPath = path
        for interop in (1, 0):
            neural.CudaGLInterop = interop
            key = "%s_%s" % (path, "interop" if interop else "host")
            out[key] = orbit_ms(view, still, neural)
            out[key + "_interactive"] = orbit_ms(view, interactive, neural)
    neural.CudaGLInterop = 1
    out["path_tracing"] = path_tracing_still(view, neural, "%dx%d" % tuple(size))
    neural.ShadingMode = "Ray Marching"
    Delete(view)
    return out


def path_tracing_still(view, neural, tag):
    """Path tracing + NEE still renders of one view (Decode; times: medians of 3, the single pass of 5, each until the
    GPU has finished the picture): one pass, the still render to TargetSamples paths with
    the denoiser (the default) and without, and a raw reference of 2 x 1024 paths; every picture's PSNR against the
    reference over the pixels the volume covers. The reference's own noise is measured, not assumed away: its first
    1024 paths (A) and the whole 2048 (C) give MSE(C, truth) ~ MSE(A, B) / 4 = MSE(A, C) (B, the second half, = 2C - A),
    so "psnr_vs_truth" = 10 log10(255^2 / (MSE(X, C) - MSE(A, C))) estimates a picture's PSNR against the converged one.
    Each render starts a new accumulation (the camera leaves and comes back)."""
    import numpy as np
    neural.RenderPath = "Decode"
    neural.ShadingMode = "Path Tracing + Next-Event Estimation"
    camera = view.GetActiveCamera()
    camera.Azimuth(5.0)

    def shot(name):
        png = os.path.join(OUT_DIR, "pt_%s_%s.png" % (tag, name))
        nvtest.shot(view, png, view.ViewSize)
        neural.SMProxy.UpdatePropertyInformation()
        return png

    def still(target, denoise, repeat=3):
        """The median time of `repeat` still renders to `target` paths, each a new accumulation (one timing alone
        jumps with the GPU's clocks and ParaView's own work: a single pass is the unit of the goal)."""
        times = []
        for _ in range(repeat):
            neural.TargetSamples = 1
            camera.Azimuth(1.0)
            Render(view)
            camera.Azimuth(-1.0)
            neural.TargetSamples = target
            neural.Denoise = denoise
            started = time.perf_counter()
            Render(view)
            # Through interop Render() returns before the GPU has drawn (the engine's work is queued): the time of
            # a still picture is until it is on the view, for one pass as for many.
            view.GetRenderWindow().WaitForCompletion()
            times.append(1000 * (time.perf_counter() - started))
        png = shot("%d_%s" % (target, "denoised" if denoise else "raw"))
        return {"ms": round(statistics.median(times), 3), "ms_each": [round(t, 3) for t in times],
                "paths": neural.GetPropertyValue("LastAccumulatedPaths"), "png": png}

    half = still(1024, 0, repeat=1)
    neural.TargetSamples = 2048  # the same accumulation goes on to 2048 paths
    Render(view)
    reference = {"png": shot("2048_raw"), "paths": neural.GetPropertyValue("LastAccumulatedPaths")}
    ref = nvtest.read_png(reference["png"]).astype(np.float64)
    first = nvtest.read_png(half["png"]).astype(np.float64)
    background = ref[0, 0]
    mask = (abs(ref - background).sum(axis=2) > 3.0)

    def mse(picture):
        return float(np.mean((picture[mask] - ref[mask]) ** 2))

    noise = mse(first)
    result = {"reference_2048_raw": reference, "reference_first_1024": half, "volume_pixels": int(mask.sum()),
              "reference_psnr_vs_truth": round(10 * math.log10(255.0 ** 2 / noise), 2) if noise > 0 else None}
    for target in (1, 4, 8, 16, 32, 64):
        for denoise in (1, 0):
            r = still(target, denoise, repeat=5 if target == 1 else 3)
            error = mse(nvtest.read_png(r["png"]).astype(np.float64))
            r["psnr_vs_reference"] = round(10 * math.log10(255.0 ** 2 / error), 2) if error > 0 else None
            r["psnr_vs_truth"] = round(10 * math.log10(255.0 ** 2 / (error - noise)), 2) if error > noise else None
            result["%d_%s" % (target, "denoised" if denoise else "raw")] = r
    one = result["1_denoised"]["ms"]
    for key, r in list(result.items()):
        if isinstance(r, dict) and "ms" in r:
            r["passes_of_one"] = round(r["ms"] / one, 2) if one > 0 else None
    neural.TargetSamples = 64
    neural.Denoise = 1
    return result


def refresh(nc):
    """The live network's refresh, as the GUI's live-source timer does it."""
    nc.SMProxy.GetClientSideObject().Modified()
    nc.SMProxy.MarkModified(nc.SMProxy)


def training_rate(source, array, size, seconds, frame_rate=None):
    """Steps per second of a background training alone (frame_rate None) or while a view of `size` turns
    (interactive renders asked for as fast as the loop goes, paced by the representation to `frame_rate` a second,
    0: not paced), and the renders per second."""
    nc = NeuralCompress(Input=source, SelectInputScalars=["POINTS", array], Device=DEVICE, TrainInBackground=1,
                        TrainingSteps=10 ** 7, TimeBudget=0, PSNRInterval=0, Log2TableSize=19)
    nc.UpdatePipeline()
    waited = time.perf_counter()
    while time.perf_counter() - waited < 120.0:  # a large field is prepared first (no steps yet)
        nc.SMProxy.UpdatePropertyInformation()
        if nc.GetPropertyValue("TotalStepsTrained") > 0:
            break
        time.sleep(0.05)
        refresh(nc)  # the job starts once an execution finds its field prepared
        nc.UpdatePipeline()
    view = None
    if frame_rate is not None:
        view = CreateRenderView()
        view.ViewSize = list(size)
        view.OrientationAxesVisibility = 0
        d = Show(nc, view)
        ColorBy(d, ("POINTS", array))
        d.SetRepresentationType("Neural Volume")
        d.SetScalarBarVisibility(view, False)
        d.MaximumInteractiveFrameRate = frame_rate
        view.ResetCamera()
    nc.SMProxy.UpdatePropertyInformation()
    steps0, t0, renders = nc.GetPropertyValue("TotalStepsTrained"), time.perf_counter(), 0
    while time.perf_counter() - t0 < seconds:
        if view is None:
            time.sleep(0.05)
            continue
        view.GetActiveCamera().Azimuth(2.0)
        refresh(nc)
        view.SMProxy.InteractiveRender()
        renders += 1
    nc.SMProxy.UpdatePropertyInformation()
    steps = nc.GetPropertyValue("TotalStepsTrained") - steps0
    elapsed = time.perf_counter() - t0
    nc.StopTraining()
    nc.WaitForTraining()
    if view is not None:
        Delete(view)
    Delete(nc)
    return steps / elapsed, renders / elapsed


def training_share(source, array, size, seconds):
    """The training's rate alone, then beside a turning view with interactive renders paced at 60 a second and not
    paced: {limit: figures}."""
    alone, _ = training_rate(source, array, size, seconds)
    shares = {}
    for limit in (60.0, 0.0):
        beside, fps = training_rate(source, array, size, seconds, limit)
        shares[limit] = {"steps_per_s_alone": round(alone, 1), "steps_per_s_beside_view": round(beside, 1),
                         "share": round(beside / alone, 3) if alone > 0 else None, "interactive_fps": round(fps, 1),
                         "frame_rate_limit": limit}
    return shares


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("plugin")
    parser.add_argument("out")
    parser.add_argument("--data")
    parser.add_argument("--n", type=int, default=256)
    parser.add_argument("--device", default="CUDA")
    parser.add_argument("--small", action="store_true")
    a = parser.parse_args()
    global DEVICE, SIZES, ORBIT, OUT_DIR
    DEVICE = a.device
    OUT_DIR = os.path.join(os.path.dirname(os.path.abspath(a.out)), os.path.basename(a.out).replace(".json", "_pictures"))
    os.makedirs(OUT_DIR, exist_ok=True)
    if a.small:
        SIZES, ORBIT = [(160, 90)], 3
    LoadPlugin(a.plugin, remote=False, ns=globals())
    paraview.simple._DisableFirstRenderCameraReset()
    if a.data:
        source, array, name = NrrdReader(FileName=a.data), "ImageFile", a.data.split("/")[-1]
    else:
        source, array, name = Wavelet(WholeExtent=[0, a.n - 1] * 3), "RTData", "wavelet%d" % a.n
    source.UpdatePipeline()
    nc = NeuralCompress(Input=source, SelectInputScalars=["POINTS", array], Device=DEVICE, TrainInBackground=0,
                        TrainingSteps=300 if a.small else 3000, PSNRInterval=0, Log2TableSize=19)
    t = time.perf_counter()
    nc.UpdatePipeline()
    data = servermanager.Fetch(nc)
    result = {"data": name, "train_s": round(time.perf_counter() - t, 3),
              "psnr": data.GetFieldData().GetArray("NeuralPSNR").GetValue(0),
              "device": data.GetFieldData().GetAbstractArray("NeuralDevice").GetValue(0)}
    for size in SIZES:
        result["%dx%d" % size] = frames(source, array, nc, size)
        print("RESULT " + json.dumps({"size": size, **result["%dx%d" % size]}), flush=True)
    shares = training_share(source, array, SIZES[-1], 1.0 if a.small else 3.0)
    result["training_share"], result["training_share_unpaced"] = shares[60.0], shares[0.0]
    for key in ("training_share", "training_share_unpaced"):
        print("RESULT " + json.dumps(result[key]), flush=True)
    with open(a.out, "w") as f:
        json.dump(result, f, indent=1)
    os._exit(0)  # no view teardown (GLX, see Testing/ParaView/nvtest.py)


main()
