"""State restore with a file source (a 256^3 float32 raw volume read by ParaView's NRRD reader, not the Wavelet):
trains a Neural Compress on the CPU (100 steps), saves a state with a layout, then (--load, under X: xvfb-run) loads
it in a new pvbatch and prints the time to the plugin, LoadState, the reader, the filter (network back, no training
step) and the first interactive (reduced) picture.
Usage: pvbatch state_restore_file.py <plugin.so> <out folder>               (writes the volume and the state)
       xvfb-run pvbatch --force-offscreen-rendering state_restore_file.py <plugin.so> <out> --load <out>/restore.pvsm
GUI: Testing/Benchmarks/state_restore_gui.sh <plugin.so> <out>/restore.pvsm (screenshots after LoadState starts)."""
import os, sys, time, subprocess
import numpy as np
from paraview.simple import *
from paraview import servermanager
from vtkmodules.util.numpy_support import vtk_to_numpy
plugin, out = sys.argv[1], sys.argv[2]
if len(sys.argv) > 3 and sys.argv[3] == "--load":
    t0 = time.time()
    LoadPlugin(plugin, remote=False, ns=globals())
    t_plugin = time.time() - t0
    t0 = time.time()
    LoadState(sys.argv[4])
    t_state = time.time() - t0
    nc = FindSource("Restore")
    t1 = time.time()
    nc.Input.UpdatePipeline()
    t_reader = time.time() - t1
    nc.UpdatePipeline()
    t_net = time.time() - t0
    print("RESULT reader %.3f filter %.3f" % (t_reader, t_net - t_state - t_reader), flush=True)
    view = GetRenderViews()[0]
    view.ViewSize = [800, 600]
    view.InteractiveRender()
    t_first = time.time() - t0
    d = GetDisplayProperties(nc, view)
    d.SMProxy.UpdatePropertyInformation()
    print("RESULT plugin %.3f loadstate %.3f network %.3f first_interactive %.3f steps %d path %d ms %.1f size %s" % (
        t_plugin, t_state, t_net, t_first, nc.GetPropertyValue("TotalStepsTrained"), d.GetPropertyValue("LastRenderPath"),
        d.GetPropertyValue("LastRenderMilliseconds"), d.GetPropertyValue("LastImageSize")), flush=True)
    sys.exit(0)
N = 256
raw = os.path.join(out, "vol256.raw")
if not os.path.exists(raw):
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, N),) * 3, indexing="ij")
    v = (np.sin(6 * x) * np.cos(5 * y) * np.sin(4 * z) + np.exp(-(x * x + y * y + z * z) * 3)).astype(np.float32)
    v.tofile(raw)
    open(os.path.join(out, "vol256.nhdr"), "w").write("NRRD0004\ntype: float\ndimension: 3\nsizes: 256 256 256\nencoding: raw\nendian: little\ndata file: vol256.raw\n")
LoadPlugin(plugin, remote=False, ns=globals())
src = OpenDataFile(os.path.join(out, "vol256.nhdr"))
nc = NeuralCompress(registrationName="Restore", Input=src, SelectInputScalars=["POINTS", "ImageFile"], TrainingSteps=100,
                    TrainInBackground=0, BatchSize=16384, Device="CPU")
nc.UpdatePipeline()
view = CreateRenderView()
layout = CreateLayout("Restore")
AssignViewToLayout(view=view, layout=layout, hint=0)
view.ViewSize = [1000, 600]
Show(nc, view)
view.ResetCamera()
state = os.path.join(out, "restore.pvsm")
SaveState(state)
print("saved", os.path.getsize(state), flush=True)
for k in range(3):
    child = subprocess.run(["xvfb-run", "-a", "pvbatch", "--force-offscreen-rendering", os.path.abspath(__file__), plugin, out, "--load", state],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    print("\n".join(l for l in child.stdout.decode(errors="replace").splitlines() if l.startswith("RESULT")), flush=True)
