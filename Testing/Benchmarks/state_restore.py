"""State restore through ParaView: a Neural Compress of a 256^3 field is trained on the CPU, saved with the state, and
the state is loaded in new pvbatch processes. Each load reports, from the moment LoadState starts: the network
restored (the filter updated, no training step), the first picture (an interactive render: reduced image, a coarse
decode grid while the full one decodes in the background), the full-quality picture (a still render, as
SaveScreenshot does), the steps trained on load (must be 0), and whether the decoded field is the saved one bit for bit.
Sources: "wavelet" (ParaView's Wavelet, regenerated on load) or "file" (a 256^3 float32 raw volume written by numpy and
read by ParaView's NRRD reader: the source's cost is then reading 64 MB, not computing the field).
With --stock the same source is also saved shown as ParaView's stock Volume, and that state is loaded the same way: the
figure the network's restore is compared with; and the network's state without its networks' bytes is loaded (LoadState
alone), which says what ParaView's state loading spends on those bytes. --device CUDA trains (and so renders) on the GPU.
Usage: xvfb-run -a pvbatch --force-offscreen-rendering state_restore.py <plugin.so> <out folder>
                 [--source wavelet|file] [--n 256] [--steps 100] [--repeat 3] [--device CPU|CUDA] [--stock]
GUI: Testing/Benchmarks/state_restore_gui.sh <plugin.so> <out folder>/restore_<source>.pvsm"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np
from paraview.simple import *  # noqa: F401,F403
from paraview import servermanager
from vtkmodules.util.numpy_support import vtk_to_numpy

VIEW_SIZE = [1000, 600]


def load(plugin, state, npy):
    t = time.time()
    LoadPlugin(plugin, remote=False, ns=globals())
    plugin_s = time.time() - t
    t0 = time.time()
    LoadState(state)
    loadstate = time.time() - t0
    if state.endswith("_stripped.pvsm"):  # LoadState alone: the state without its networks' bytes
        print("RESULT " + json.dumps(dict(what="paraview_stripped_state_load", loadstate_s=round(loadstate, 3))),
              flush=True)
        os._exit(0)
    nc = FindSource("Restore")
    if nc is None:  # the stock state: the source shown as Volume
        view = GetRenderViews()[0]
        view.ViewSize = VIEW_SIZE
        view.InteractiveRender()
        first = time.time() - t0
        Render(view)
        full = time.time() - t0
        print("RESULT " + json.dumps(dict(what="paraview_stock_state_restore", plugin_s=round(plugin_s, 3),
                                          loadstate_s=round(loadstate, 3), first_picture_s=round(first, 3),
                                          full_picture_s=round(full, 3))), flush=True)
        os._exit(0)
    t = time.time()
    nc.Input.UpdatePipeline()
    source = time.time() - t
    nc.UpdatePipeline()
    network = time.time() - t0
    view = GetRenderViews()[0]
    view.ViewSize = VIEW_SIZE
    display = GetDisplayProperties(nc, view)
    view.InteractiveRender()
    first = time.time() - t0
    display.SMProxy.UpdatePropertyInformation()
    first_size = list(display.GetPropertyValue("LastImageSize"))
    first_coarse = display.GetPropertyValue("WorkPending")
    Render(view)
    full = time.time() - t0
    display.SMProxy.UpdatePropertyInformation()
    nc.SMProxy.UpdatePropertyInformation()
    result = dict(what="paraview_state_restore", plugin_s=round(plugin_s, 3), loadstate_s=round(loadstate, 3),
                  source_s=round(source, 3), filter_s=round(network - loadstate - source, 3),
                  network_restored_s=round(network, 3), first_picture_s=round(first, 3), first_image=first_size,
                  first_coarse=first_coarse, full_picture_s=round(full, 3),
                  full_image=list(display.GetPropertyValue("LastImageSize")),
                  full_pending=display.GetPropertyValue("WorkPending"),
                  steps_trained=nc.GetPropertyValue("TotalStepsTrained"))
    t = time.time()
    nc.OutputMode = "Decoded, float32"
    nc.UpdatePipeline()
    array = servermanager.Fetch(nc).GetPointData().GetArray(nc.SelectInputScalars[1])
    result["decoded_after_render_s"] = round(time.time() - t, 3)
    np.save(npy, vtk_to_numpy(array))
    print("RESULT " + json.dumps(result), flush=True)
    sys.stdout.flush()
    os._exit(0)  # no view teardown (GLX, see Testing/ParaView/nvtest.py)


def save(plugin, out, source, n, steps, device):
    os.makedirs(out, exist_ok=True)
    LoadPlugin(plugin, remote=False, ns=globals())
    if source == "file":
        raw = os.path.join(out, "vol%d.raw" % n)
        if not os.path.exists(raw):
            z, y, x = np.meshgrid(*(np.linspace(-1, 1, n),) * 3, indexing="ij")
            v = np.sin(6 * x) * np.cos(5 * y) * np.sin(4 * z) + np.exp(-(x * x + y * y + z * z) * 3)
            v.astype(np.float32).tofile(raw)
        header = os.path.join(out, "vol%d.nhdr" % n)
        with open(header, "w") as f:
            f.write("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nendian: little\n"
                    "data file: %s\n" % (n, n, n, os.path.basename(raw)))
        src, array = OpenDataFile(header), "ImageFile"
    else:
        src, array = Wavelet(WholeExtent=[0, n - 1] * 3), "RTData"
    nc = NeuralCompress(registrationName="Restore", Input=src, SelectInputScalars=["POINTS", array],
                        TrainingSteps=steps, TrainInBackground=0, BatchSize=16384, Device=device)
    nc.UpdatePipeline()
    view = CreateRenderView()
    layout = CreateLayout("Restore")
    AssignViewToLayout(view=view, layout=layout, hint=0)
    view.ViewSize = VIEW_SIZE
    Show(nc, view)
    view.ResetCamera()
    state = os.path.join(out, "restore_%s.pvsm" % source)
    SaveState(state)
    nc.OutputMode = "Decoded, float32"
    nc.UpdatePipeline()
    data = servermanager.Fetch(nc)
    saved = vtk_to_numpy(data.GetPointData().GetArray(array)).copy()
    Delete(nc)
    stock = Show(src, view)
    ColorBy(stock, ("POINTS", array))
    stock.SetRepresentationType("Volume")
    SaveState(os.path.join(out, "stock_%s.pvsm" % source))
    print("RESULT " + json.dumps(dict(
        what="paraview_state_saved", source=source, n=n, steps=steps, state_bytes=os.path.getsize(state),
        model_bytes=int(data.GetFieldData().GetArray("NeuralModelBytes").GetValue(0)),
        ratio=round(data.GetFieldData().GetArray("NeuralCompressionRatio").GetValue(0), 2))), flush=True)
    return state, saved


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("plugin")
    parser.add_argument("out")
    parser.add_argument("--source", choices=["wavelet", "file"], default="file")
    parser.add_argument("--n", type=int, default=256)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--device", default="CPU")
    parser.add_argument("--stock", action="store_true")
    parser.add_argument("--load", help=argparse.SUPPRESS)
    parser.add_argument("--npy", help=argparse.SUPPRESS)
    a = parser.parse_args()
    if a.load:
        load(a.plugin, a.load, a.npy)
    state, saved = save(a.plugin, a.out, a.source, a.n, a.steps, a.device)
    runs = []
    for k in range(a.repeat):
        npy = os.path.join(a.out, "restored_%d.npy" % k)
        child = subprocess.run(["pvbatch", "--force-offscreen-rendering", os.path.abspath(__file__), a.plugin, a.out,
                                "--load", state, "--npy", npy], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        lines = [l for l in child.stdout.decode(errors="replace").splitlines() if l.startswith("RESULT ")]
        if not lines:
            print(child.stdout.decode(errors="replace")[-3000:])
            continue
        r = json.loads(lines[-1][7:])
        r["bit_identical"] = bool(os.path.exists(npy) and np.array_equal(np.load(npy), saved))
        print("RESULT " + json.dumps(r), flush=True)
        runs.append(r)
    stock_runs = []
    for k in range(a.repeat if a.stock else 0):
        child = subprocess.run(["pvbatch", "--force-offscreen-rendering", os.path.abspath(__file__), a.plugin, a.out,
                                "--load", os.path.join(a.out, "stock_%s.pvsm" % a.source)],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        lines = [l for l in child.stdout.decode(errors="replace").splitlines() if l.startswith("RESULT ")]
        if lines:
            print(lines[-1], flush=True)
            stock_runs.append(json.loads(lines[-1][7:]))
    stripped_runs = []
    for k in range(a.repeat if a.stock else 0):
        stripped = strip_networks(state)
        child = subprocess.run(["pvbatch", "--force-offscreen-rendering", os.path.abspath(__file__), a.plugin, a.out,
                                "--load", stripped], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        lines = [l for l in child.stdout.decode(errors="replace").splitlines() if l.startswith("RESULT ")]
        if lines:
            print(lines[-1], flush=True)
            stripped_runs.append(json.loads(lines[-1][7:]))
    keys = ["loadstate_s", "source_s", "filter_s", "network_restored_s", "first_picture_s", "full_picture_s",
            "decoded_after_render_s"]
    summary = {k: [min(r[k] for r in runs), max(r[k] for r in runs)] for k in keys if runs}
    summary.update(what="paraview_state_restore_summary", source=a.source, runs=len(runs),
                   steps_trained=sorted({r["steps_trained"] for r in runs}),
                   bit_identical=all(r["bit_identical"] for r in runs) and bool(runs), device=a.device)
    if stock_runs:
        summary["stock_first_picture_s"] = [min(r["first_picture_s"] for r in stock_runs),
                                            max(r["first_picture_s"] for r in stock_runs)]
        summary["stock_full_picture_s"] = [min(r["full_picture_s"] for r in stock_runs),
                                           max(r["full_picture_s"] for r in stock_runs)]
    if stripped_runs:
        summary["stripped_loadstate_s"] = [min(r["loadstate_s"] for r in stripped_runs),
                                           max(r["loadstate_s"] for r in stripped_runs)]
    print("RESULT " + json.dumps(summary), flush=True)
    os._exit(0)


def strip_networks(state):
    """A copy of the state whose TrainedNetworks value is empty: its LoadState time, against the whole state's, is
    what ParaView's state loading spends on the networks' bytes (read, parsed, checked, pushed)."""
    text = open(state).read()
    start = text.find('value="', text.find('name="TrainedNetworks"')) + len('value="')
    stripped = state[:-len(".pvsm")] + "_stripped.pvsm"
    with open(stripped, "w") as f:
        f.write(text[:start] + text[text.find('"', start):])
    return stripped


main()
