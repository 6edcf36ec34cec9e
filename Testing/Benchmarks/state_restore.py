"""State restore through ParaView: a Neural Compress of a 256^3 field is trained, saved with the state, and the state is
loaded in a new pvbatch process; reports the state file size, the time to the first rendered picture and the steps
trained on load (must be 0), and checks the decoded field is the saved one bit for bit.
Usage: pvbatch --force-offscreen-rendering state_restore.py <plugin.so> <out folder> [N=256] [steps=200]"""
import os
import subprocess
import sys
import time

import numpy as np
from paraview.simple import *  # noqa: F401,F403
from paraview import servermanager
from vtkmodules.util.numpy_support import vtk_to_numpy

plugin, out = sys.argv[1], sys.argv[2]
if len(sys.argv) > 3 and sys.argv[3] == "--load":
    LoadPlugin(plugin, remote=False, ns=globals())
    state, view_size = sys.argv[4], [1280, 720]
    t0 = time.time()
    LoadState(state)
    nc = FindSource("Restore")
    nc.UpdatePipeline()
    restored_network = time.time() - t0
    view = GetRenderViews()[0] if GetRenderViews() else CreateRenderView()
    view.ViewSize = view_size
    Render(view)
    first_picture = time.time() - t0
    nc.SMProxy.UpdatePropertyInformation()
    nc.OutputMode = "Decoded, float32"
    nc.UpdatePipeline()
    np.save(os.path.join(out, "restored.npy"), vtk_to_numpy(servermanager.Fetch(nc).GetPointData().GetArray("RTData")))
    display = GetDisplayProperties(nc, view)
    display.SMProxy.UpdatePropertyInformation()
    print("RESULT {\"what\":\"paraview_state_restore\",\"network_restored_s\":%.3f,\"first_picture_s\":%.3f,"
          "\"render_path\":%d,\"render_ms\":%.1f,\"steps_trained\":%d}"
          % (restored_network, first_picture, display.GetPropertyValue("LastRenderPath"),
             display.GetPropertyValue("LastRenderMilliseconds"), nc.GetPropertyValue("TotalStepsTrained")))
    sys.exit(0)

N = int(sys.argv[3]) if len(sys.argv) > 3 else 256
steps = int(sys.argv[4]) if len(sys.argv) > 4 else 200
os.makedirs(out, exist_ok=True)
LoadPlugin(plugin, remote=False, ns=globals())
src = Wavelet(WholeExtent=[0, N - 1] * 3)
nc = NeuralCompress(registrationName="Restore", Input=src, SelectInputScalars=["POINTS", "RTData"],
                    TrainingSteps=steps, TrainInBackground=0, BatchSize=16384)
nc.UpdatePipeline()
view = CreateRenderView()
Show(nc, view)
view.ResetCamera()
Render(view)
state = os.path.join(out, "restore.pvsm")
SaveState(state)
nc.OutputMode = "Decoded, float32"
nc.UpdatePipeline()
saved = vtk_to_numpy(servermanager.Fetch(nc).GetPointData().GetArray("RTData")).copy()
data = servermanager.Fetch(nc)
print("RESULT {\"what\":\"paraview_state_saved\",\"n\":%d,\"state_bytes\":%d,\"model_bytes\":%d,\"ratio\":%.2f}"
      % (N, os.path.getsize(state), data.GetFieldData().GetArray("NeuralModelBytes").GetValue(0),
         data.GetFieldData().GetArray("NeuralCompressionRatio").GetValue(0)))
sys.stdout.flush()
child = subprocess.run([sys.executable if "pvbatch" in sys.executable else "pvbatch", "--force-offscreen-rendering",
                        os.path.abspath(__file__), plugin, out, "--load", state], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT)
text = child.stdout.decode(errors="replace")
print("\n".join(line for line in text.splitlines() if line.startswith("RESULT")))
restored = np.load(os.path.join(out, "restored.npy"))
print("RESULT {\"what\":\"paraview_state_bit_identical\",\"value\":%s}" % ("true" if np.array_equal(restored, saved)
                                                                            else "false"))
