"""The CUDA engine inside ParaView (label gpu-paraview; SKIP without a usable GPU): Neural Compress trains with Device
CUDA in the background while a render view draws its Neural Volume, then every render path x shading mode is drawn by
the CUDA session and compared with the CPU engine's picture of the same network (the CPU oracle: the network saved to
.nvol and drawn by a second pvbatch that sees no GPU, CUDA_VISIBLE_DEVICES empty), and the time of a Render() of each
path as ParaView shows it is logged (median of a camera orbit).

    pvbatch TestGpuParaView.py            the test (both processes)
    pvbatch TestGpuParaView.py --draw DIR NVOL DEVICE   one process's pictures (used by the test)
"""
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
import paraview.simple  # noqa: E402

paraview.simple._DisableFirstRenderCameraReset()  # both processes draw from the camera set here

check, log = nvtest.check, nvtest.log
SIZE = [640, 360]
PATHS = ["Decode", "Sample Streaming", "In-Shader"]
MODES = ["Ray Marching", "Ray Marching + Gradient Shading", "Ray Marching + Shadows", "Path Tracing",
         "Path Tracing + Next-Event Estimation"]
# GPU against CPU of the same network: ray marching differs by float rounding only; path tracing by the noise of two
# independent estimates of TargetSamples paths per pixel (the engine's GPU suite: 37.7-50.2 dB at 1-2 spp).
MIN_PSNR = {"Ray Marching": 40.0, "Ray Marching + Gradient Shading": 35.0, "Ray Marching + Shadows": 35.0,
            "Path Tracing": 25.0, "Path Tracing + Next-Event Estimation": 28.0}
TARGET_SAMPLES = 64


def picture_name(tag, path, mode):
    return ("%s_%s_%s.png" % (tag, path, mode)).replace(" + ", "_").replace(" ", "").replace("-", "")


def styled_view(source, array, vmin, vmax):
    view = nvtest.render_view(SIZE)
    display = nvtest.show_styled(source, view, array, vmin, vmax, 0.55)
    display.Representation = "Neural Volume"
    nvtest.set_camera(view, (130.0, -90.0, 70.0), focal=(0.0, 0.0, 0.0))
    display.TargetSamples = TARGET_SAMPLES
    return view, display


def draw_all(view, display, out_dir, tag):
    """Every path x mode as a still picture; the Render() time of each path (ray marching) while orbiting."""
    timings = {}
    # The same camera in both processes (set on the camera itself: orbits through it leave the proxy's values stale).
    camera = view.GetActiveCamera()
    camera.SetPosition(130.0, -90.0, 70.0)
    camera.SetFocalPoint(0.0, 0.0, 0.0)
    camera.SetViewUp(0.0, 0.0, 1.0)
    camera.SetViewAngle(30.0)
    for path in PATHS:
        display.RenderPath = path
        for mode in MODES:
            display.ShadingMode = mode
            Render(view)
            nvtest.shot(view, os.path.join(out_dir, picture_name(tag, path, mode)), SIZE)
        display.ShadingMode = "Ray Marching"
        Render(view)
        seconds = []
        for k in range(30):
            camera.Azimuth(3.0)
            started = time.perf_counter()
            Render(view)
            seconds.append(time.perf_counter() - started)
        timings[path] = {"median_ms": 1000 * statistics.median(seconds), "engine_ms": nvtest.info(
            display, "LastRenderMilliseconds")}
        camera.Azimuth(-90.0)
    return timings


def draw_process(out_dir, nvol, device):
    """Second process: the saved network drawn by this process's engine (the CPU when no GPU is visible)."""
    nvtest.load_plugin(globals(), scripted=False)
    reader = OpenDataFile(nvol)
    reader.UpdatePipeline()
    data = servermanager.Fetch(reader)
    rng = data.GetFieldData().GetArray("NeuralValueRange")
    vmin, vmax = (rng.GetValue(0), rng.GetValue(1)) if rng else (37.0, 277.0)
    view, display = styled_view(reader, "RTData", vmin, vmax)
    timings = draw_all(view, display, out_dir, device)
    with open(os.path.join(out_dir, "%s_timings.json" % device), "w") as f:
        json.dump(timings, f)
    nvtest.finish()


def gpu_usable():
    """A tiny training with Device CUDA: does this build and machine have a usable GPU?"""
    probe = NeuralCompress(Input=Wavelet(WholeExtent=[0, 7] * 3), SelectInputScalars=["POINTS", "RTData"],
                           Device="CUDA", TrainingSteps=1, TrainInBackground=0)
    probe.UpdatePipeline()
    device = nvtest.field_value(servermanager.Fetch(probe), "NeuralDevice")
    Delete(probe)
    return device is not None and "CPU" not in str(device)


def main():
    nvtest.load_plugin(globals(), scripted=False)
    out_dir = nvtest.output_dir()
    if not gpu_usable():
        nvtest.skip("no usable GPU in this build or on this machine")
    wavelet = Wavelet(WholeExtent=[-63, 64] * 3)
    wavelet.UpdatePipeline()
    vmin, vmax = wavelet.PointData["RTData"].GetRange()
    nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], Device="CUDA", TrainInBackground=1,
                        TrainingSteps=3000, TimeBudget=0, Log2TableSize=19, PSNRInterval=250)
    started = time.perf_counter()
    nc.UpdatePipeline()
    apply_s = time.perf_counter() - started
    view, display = styled_view(nc, "RTData", vmin, vmax)
    # 1. Training while the view draws the live network (a render loop as a user's rotation would make).
    renders, camera = 0, view.GetActiveCamera()
    end = time.perf_counter() + 3.0
    while time.perf_counter() < end:
        camera.Azimuth(2.0)
        nc.SMProxy.GetClientSideObject().Modified()
        nc.SMProxy.MarkModified(nc.SMProxy)
        Render(view)
        renders += 1
    nc.SMProxy.UpdatePropertyInformation()
    live_steps = nc.GetPropertyValue("TotalStepsTrained")
    live_status = nc.GetPropertyValue("TrainingStatus")
    nc.WaitForTraining()
    nc.UpdatePipeline()
    data = servermanager.Fetch(nc)
    device = nvtest.field_value(data, "NeuralDevice")
    psnr = nvtest.field_value(data, "NeuralPSNR")
    log("Apply %.3f s; %d renders in 3 s while training (%d steps then, %r); finished on %s: PSNR %.2f dB"
        % (apply_s, renders, live_steps, live_status, device, psnr))
    check(device is not None and "CPU" not in str(device), "trained on the GPU (%s)" % device)
    check(live_steps > 0 and renders >= 10, "training went on while the view rendered (%d steps, %d renders)"
          % (live_steps, renders))
    check(psnr is not None and psnr > 35.0, "the trained network reaches 35 dB (%s)" % psnr)
    # 2. Every path x mode on the GPU, then the same network on the CPU in a process without a GPU.
    nvol = os.path.join(out_dir, "gpu_paraview.nvol")
    SaveData(nvol, proxy=nc)
    gpu_timings = draw_all(view, display, out_dir, "gpu")
    env = dict(os.environ, CUDA_VISIBLE_DEVICES="")
    pvbatch = os.environ.get("NV_PVBATCH", "pvbatch")
    cpu = subprocess.run([pvbatch, "--force-offscreen-rendering", os.path.abspath(__file__), "--draw", out_dir,
                          nvol, "cpu"], env=env, timeout=1200, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    log(cpu.stdout.decode(errors="replace")[-3000:])
    check(cpu.returncode == 0, "the CPU oracle drew every picture (exit %d)" % cpu.returncode)
    for path in PATHS:
        for mode in MODES:
            a = nvtest.read_png(os.path.join(out_dir, picture_name("gpu", path, mode)))
            b = nvtest.read_png(os.path.join(out_dir, picture_name("cpu", path, mode)))
            db = nvtest.image_psnr(a, b)
            check(db >= MIN_PSNR[mode] and a.std() > 3.0, "%s, %s: GPU vs CPU %.1f dB (>= %.0f), not blank"
                  % (path, mode, db, MIN_PSNR[mode]))
    with open(os.path.join(out_dir, "cpu_timings.json")) as f:
        cpu_timings = json.load(f)
    for path in PATHS:
        log("%s, ray marching, %dx%d: Render() median %.1f ms on the GPU (engine %.1f ms), %.1f ms on the CPU"
            % (path, SIZE[0], SIZE[1], gpu_timings[path]["median_ms"], gpu_timings[path]["engine_ms"],
               cpu_timings[path]["median_ms"]))
    with open(os.path.join(out_dir, "gpu_paraview.json"), "w") as f:
        json.dump({"apply_s": apply_s, "renders_while_training": renders, "steps_while_rendering": live_steps,
                   "psnr": psnr, "device": device, "gpu": gpu_timings, "cpu": cpu_timings}, f, indent=1)
    nvtest.finish()


if len(sys.argv) > 4 and sys.argv[1] == "--draw":
    nvtest.fail_on_exception(draw_process)(sys.argv[2], sys.argv[3], sys.argv[4])
else:
    nvtest.fail_on_exception(main)()
