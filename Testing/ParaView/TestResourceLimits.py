"""Inputs that size an allocation, a thread count or a long decode end in a clear message or a capped result, within
30 s and a bounded memory, under an address-space limit -- never a signal or a hang (the issue's stress run).

Each case runs in a pvbatch process of its own under `ulimit -v` (LIMIT_GB, set with setrlimit before pvbatch
starts; pvbatch itself with the plugin and a render view maps about 1.5-2 GB) and a time limit. The parent takes the
child's exit status and peak resident memory from wait4() and judges: a normal exit (no signal), the expected message,
at most CASE_SECONDS, at most the case's RSS bound. The child checks what it produced with numpy (the capped output's
dims, its values against the source resampled at those dims) and writes its verdicts to a JSON file.

Cases: OutputResolution 1600^3 (capped at the network's finest level, and with FinestResolution 2048 refused against
the process's limit "(ulimit -v)"), OutputResolution [2^31-1, 1, 1], Threads 1024, DecodeResolution 4096^3,
2048 x 2048 x 1024 and 65536 x 65536 x 2 of the Neural Volume representation, and a long decode (2^28 samples, within the caps) aborted from
a progress observer, which must stop within a second.
"""
import json
import os
import resource
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

LIMIT_GB = 8
CASE_SECONDS = 30.0
KILL_SECONDS = 120.0  # a child still running then hangs: killed, the case fails
MB = 1024 * 1024
# A 16^3 Wavelet and a small network: trains in about a second on two cores; its finest level (the default,
# FinestResolution 0) is twice the largest dimension: 32 samples per axis, decoded at most 64 (nv::kDecodeOversampling).
BASE = dict(TrainInBackground=0, OutputMode=2, TrainingSteps=1000, TimeBudget=5.0, BatchSize=4096, Levels=8,
            FeaturesPerLevel=2, NetworkWidth=16, HiddenLayers=1, Threads=2, PSNRInterval=0, Loss=1)
CASES = [
    dict(name="OutputResolution 1600^3", set={"OutputResolution": [1600] * 3}, rss_mb=2000,
         expect="is finer than the network resolves (its finest level has 32 samples per axis, decoded at most 2x as "
         "fine): the output is decoded at 64 x 64 x 64 instead", dims=[64, 64, 64]),
    dict(name="OutputResolution 1600^3, FinestResolution 2048", rss_mb=2000,
         set={"OutputResolution": [1600] * 3, "FinestResolution": [2048]},
         expect="(ulimit -v)", error="the decoded output needs about 16.4 GB of host memory"),
    dict(name="OutputResolution [2^31-1, 1, 1]", set={"OutputResolution": [2 ** 31 - 1, 1, 1]}, rss_mb=2000,
         expect="the output is decoded at 64 x 1 x 1 instead", dims=[64, 1, 1]),
    dict(name="Threads 1024", set={"Threads": [1024]}, rss_mb=2000,
         expect="Threads 1024 is more than 4 x the", dims=[16, 16, 16]),
    dict(name="DecodeResolution 4096^3", render={"DecodeResolution": [4096] * 3}, rss_mb=2500,
         expect="the network is decoded at 64 x 64 x 64 instead"),
    dict(name="DecodeResolution 2048 x 2048 x 1024", render={"DecodeResolution": [2048, 2048, 1024]}, rss_mb=2500,
         expect="the network is decoded at 64 x 64 x 64 instead"),
    dict(name="DecodeResolution 65536 x 65536 x 2", render={"DecodeResolution": [65536, 65536, 2]}, rss_mb=2500,
         expect="the network is decoded at 64 x 64 x 2 instead"),
    # 2^20 x 2^8 samples (1 GB of float32), within what a FinestResolution 2^20 network resolves and the limit.
    dict(name="a decode of 2^28 samples aborted", abort=True, rss_mb=3000,
         set={"OutputMode": [2], "FinestResolution": [2 ** 20], "OutputResolution": [2 ** 20, 2 ** 8, 1]},
         expect="aborted"),
]


# --- a case, in its own pvbatch --------------------------------------------------------------------------------------

def set_raw(proxy, name, values):
    prop = proxy.SMProxy.GetProperty(name)
    for i, v in enumerate(values):
        prop.SetElement(i, v)
    proxy.SMProxy.UpdateVTKObjects()


def new_filter(wavelet, overrides):
    nc = globals()["NeuralCompress"](Input=wavelet)
    set_raw(nc, "SelectInputScalars", ["0", "0", "0", "0", "RTData"])
    for k, v in BASE.items():
        set_raw(nc, k, [v])
    for k, v in overrides.items():
        set_raw(nc, k, v)
    return nc


def check_values(nc, wavelet, case, verdicts):
    """The capped output has the capped dims and values close to the source resampled at them."""
    import numpy as np
    from paraview import servermanager
    from paraview.simple import ResampleToImage
    from vtkmodules.util.numpy_support import vtk_to_numpy
    data = servermanager.Fetch(nc)
    dims = list(data.GetDimensions())
    verdicts.append(["dims %s, expected %s" % (dims, case["dims"]), dims == case["dims"]])
    array = data.GetPointData().GetArray("RTData")
    if array is None:
        verdicts.append(["no decoded RTData", False])
        return
    decoded = vtk_to_numpy(array).astype(np.float64)
    vmin, vmax = wavelet.PointData["RTData"].GetRange()
    # Finite and about in the source's range (a 16^3 field after 1000 steps overshoots its extremes by ~10%).
    verdicts.append(["decoded values finite and within the range +- 25%% (%.1f to %.1f for %.1f to %.1f)"
                     % (decoded.min(), decoded.max(), vmin, vmax),
                     bool(np.isfinite(decoded).all() and decoded.min() > vmin - 0.25 * (vmax - vmin)
                          and decoded.max() < vmax + 0.25 * (vmax - vmin))])
    if min(dims) > 1:
        reference = ResampleToImage(Input=wavelet, UseInputBounds=1, SamplingDimensions=dims)
        ref = vtk_to_numpy(servermanager.Fetch(reference).GetPointData().GetArray("RTData")).astype(np.float64)
        error = float(np.abs(decoded - ref).mean() / (vmax - vmin))
        verdicts.append(["mean |decoded - source resampled| = %.4f of the range (at most 0.05)" % error, error < 0.05])


def run_case(case, result_path):
    from paraview.simple import Wavelet, Show, Render, ColorBy, GetColorTransferFunction
    from paraview import servermanager
    nvtest.load_plugin(globals(), scripted=False)
    wavelet = Wavelet(WholeExtent=[0, 15] * 3)
    verdicts = []
    result = dict()
    with nvtest.captured_messages() as messages:
        if "render" in case:
            nc = new_filter(wavelet, {"OutputMode": [0]})
            nc.UpdatePipeline()
            view = nvtest.render_view([64, 64], (0.1, 0.1, 0.1))
            nvtest.set_camera(view, [40.0, -30.0, 55.0], focal=(7.5, 7.5, 7.5))
            display = Show(nc, view)
            ColorBy(display, ("POINTS", "RTData"))
            display.SetRepresentationType("Neural Volume")
            GetColorTransferFunction("RTData").RescaleTransferFunction(0.0, 300.0)
            Render(view)
            renders = nvtest.info(display, "EngineRenderCount")
            for k, v in case["render"].items():
                set_raw(display, k, v)
            started = time.time()
            Render(view)
            result["render_seconds"] = round(time.time() - started, 2)
            verdicts.append(["a new picture", nvtest.info(display, "EngineRenderCount") > renders])
        elif case.get("abort"):
            nc = new_filter(wavelet, case["set"])
            aborted_at = []

            def stop(caller, event):
                # Training reports up to 0.95, the decode beyond: abort once the decode has begun.
                if caller.GetProgress() > 0.9505 and not aborted_at:
                    aborted_at.append(time.time())
                    caller.SetAbortExecute(1)
            nc.GetClientSideObject().AddObserver("ProgressEvent", stop)
            nc.UpdatePipeline()
            ended = time.time()
            data = servermanager.Fetch(nc)
            verdicts.append(["the decode reported progress and was aborted", bool(aborted_at)])
            if aborted_at:
                result["abort_seconds"] = round(ended - aborted_at[0], 3)
                verdicts.append(["stopped %.3f s after the abort (at most 1 s)" % (ended - aborted_at[0]),
                                 ended - aborted_at[0] <= 1.0])
            verdicts.append(["the network only (no decoded array)", data.GetPointData().GetNumberOfArrays() == 0
                             and data.GetFieldData().GetArray("NeuralNetwork") is not None])
        else:
            nc = new_filter(wavelet, case["set"])
            nc.UpdatePipeline()
            if "dims" in case:
                check_values(nc, wavelet, case, verdicts)
            if "error" in case:
                data = servermanager.Fetch(nc)
                verdicts.append(["no decoded array", data.GetPointData().GetNumberOfArrays() == 0])
    result["message"] = messages[0][:4000]
    result["verdicts"] = verdicts
    with open(result_path, "w") as f:
        json.dump(result, f)
    nvtest._exit(0)


# --- the parent: one limited pvbatch per case ------------------------------------------------------------------------

def limit_address_space():
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT_GB * 1024 ** 3, resource.RLIM_INFINITY))


def spawn(index, result_path):
    """Runs case `index` under the limits: (exit status or signal text, seconds, peak RSS in MB, log text)."""
    env = dict(os.environ, NV_LIMITS_CASE="%d:%s" % (index, result_path))
    command = [os.environ.get("NV_PVBATCH", "pvbatch"), "--force-offscreen-rendering", os.path.abspath(__file__)]
    log_path = result_path + ".log"
    with open(log_path, "w") as log_file:
        started = time.time()
        child = subprocess.Popen(command, env=env, stdout=log_file, stderr=subprocess.STDOUT,
                                 preexec_fn=limit_address_space)
        status = None
        while status is None:
            pid, raw, usage = os.wait4(child.pid, os.WNOHANG)
            if pid == child.pid:
                status = raw
            elif time.time() - started > KILL_SECONDS:
                child.kill()
                pid, raw, usage = os.wait4(child.pid, 0)
                status = "hung"
            else:
                time.sleep(0.05)
        seconds = time.time() - started
    child.returncode = 0  # reaped by wait4
    if status != "hung":
        status = "signal %d" % os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
    with open(log_path) as f:
        text = f.read()
    return status, seconds, usage.ru_maxrss / 1024.0, text


def main():
    nvtest.require_display()
    out = nvtest.output_dir()
    rows = []
    for index, case in enumerate(CASES):
        result_path = os.path.join(out, "limits-%d.json" % index)
        if os.path.exists(result_path):
            os.remove(result_path)
        status, seconds, rss, text = spawn(index, result_path)
        name = case["name"]
        result = {}
        if os.path.exists(result_path):
            with open(result_path) as f:
                result = json.load(f)
        message = result.get("message", "") + text
        nvtest.check(status == 0, "%s: the pvbatch ended with %s: %s" % (name, status, text[-1500:]))
        nvtest.check(seconds <= CASE_SECONDS, "%s: took %.1f s (at most %.0f s)" % (name, seconds, CASE_SECONDS))
        nvtest.check(rss <= case["rss_mb"], "%s: peak RSS %.0f MB (at most %d MB)" % (name, rss, case["rss_mb"]))
        nvtest.check(case["expect"] in message, "%s: the messages do not say %r: %r" % (name, case["expect"],
                                                                                        message[:1500]))
        if "error" in case:
            nvtest.check(case["error"] in message and "ERROR" in message,
                         "%s: no error saying %r: %r" % (name, case["error"], message[:1500]))
        for what, ok in result.get("verdicts", []):
            nvtest.check(ok, "%s: %s" % (name, what))
        nvtest.check("verdicts" in result, "%s: the case wrote no result" % name)
        # The message line that names the cap or the limit, for the README's table.
        lines = [l.strip() for l in message.splitlines() if case["expect"] in l]
        rows.append((name, seconds, rss, status, lines[0][:300] if lines else ""))
        nvtest.log("%s: %s, %.1f s, peak RSS %.0f MB%s%s; %s" % (
            name, "exit %s" % status, seconds, rss,
            ", render %.2f s" % result["render_seconds"] if "render_seconds" in result else "",
            ", stopped %.3f s after the abort" % result["abort_seconds"] if "abort_seconds" in result else "",
            lines[0][:300] if lines else "(no message)"))
    nvtest.finish()


if os.environ.get("NV_LIMITS_CASE"):
    index, path = os.environ["NV_LIMITS_CASE"].split(":", 1)
    run_case(CASES[int(index)], path)
else:
    main()
