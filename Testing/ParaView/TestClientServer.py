"""Client-server: a pvserver on loopback runs Neural Compress; the network and its metadata reach the client
intact (NeuralNetwork bytes decode to the same model), and the Neural Volume render made by the server matches
the built-in session's render of the same pipeline."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

check, log = nvtest.check, nvtest.log
nvtest.require_display()
out_dir = nvtest.output_dir()
PARAMS = dict(TrainingSteps=150, BatchSize=16384, Threads=2, Seed=3, PSNRInterval=0, **nvtest.SCRIPTED)


def pipeline_and_render(png, remote):
    src = Wavelet(WholeExtent=[-24, 24, -24, 24, -24, 24])
    nc = NeuralCompress(Input=src, **PARAMS)
    nc.SelectInputScalars = ["POINTS", "RTData"]
    nc.UpdatePipeline()
    data = servermanager.Fetch(nc)
    view = CreateRenderView()
    view.ViewSize = [300, 300]
    view.OrientationAxesVisibility = 0
    view.Background = [0, 0, 0]
    rep = Show(nc, view)
    rep.SetRepresentationType("Neural Volume")
    ColorBy(rep, ("POINTS", "RTData"))
    view.CameraPosition = [90, -120, 70]
    view.CameraFocalPoint = [0, 0, 0]
    view.CameraViewUp = [0, 0, 1]
    view.ResetCamera()
    Render(view)
    SaveScreenshot(png, view, ImageResolution=[300, 300])
    check(rep.Representation == "Neural Volume" and list(rep.ColorArrayName) == ["POINTS", "RTData"],
          "shown as Neural Volume coloured by the network")
    if not remote:
        # (Information properties are read on the client, which does not render in a client-server session; the
        # remote render is checked through its image below.)
        check(nvtest.info(rep, "EngineRenderCount") >= 1, "the engine rendered")
        check(nvtest.info(rep, "SessionFromBytes") == 0, "the renderer uses the session the filter trained")
    return data


pvserver = os.path.join(os.path.dirname(sys.executable), "pvserver")
if not os.path.exists(pvserver):
    pvserver = "pvserver"
with nvtest.pvserver(pvserver, "ClientServer_pvserver.log") as (server, port):
    check(server.poll() is None, "pvserver is running on port %d" % port)
    Connect("127.0.0.1", port)
    check(servermanager.ActiveConnection.IsRemote(), "connected to a remote server")
    LoadPlugin(nvtest.plugin_path(), remote=True, ns=globals())
    LoadPlugin(nvtest.plugin_path(), remote=False, ns=globals())
    remote_png = os.path.join(out_dir, "ClientServer_remote.png")
    remote = pipeline_and_render(remote_png, True)
    net = remote.GetFieldData().GetArray("NeuralNetwork")
    check(net is not None and net.GetNumberOfTuples() > 1000, "NeuralNetwork delivered to the client")
    remote_bytes = bytes(vtk_to_numpy(net)) if net is not None else b""
    check(remote_bytes[:8] == b"NVOLNET\0", "delivered network starts with the format magic")
    remote_psnr = nvtest.field_value(remote, "NeuralPSNR")
    remote_field = vtk_to_numpy(remote.GetPointData().GetArray("RTData")).copy()
    check(remote_field.size == 49 ** 3 and np.all(np.isfinite(remote_field)), "decoded field delivered")
    # Background training on the server: the update returns while it trains; the controls reach the server.
    online = NeuralCompress(Input=Wavelet(WholeExtent=[-24, 24] * 3), SelectInputScalars=["POINTS", "RTData"],
                            TrainingSteps=400, BatchSize=4096, Threads=2, TrainInBackground=1)
    online.UpdatePipeline()
    first = servermanager.Fetch(online).GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0)
    online.PauseTraining()
    online.UpdatePipeline()
    paused = servermanager.Fetch(online).GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0)
    online.ResumeTraining()
    online.WaitForTraining()
    online.UpdatePipeline()
    done = servermanager.Fetch(online)
    log("client-server background run: %s, then %s, then %s at %d steps" % (
        first, paused, done.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0),
        nvtest.field_value(done, "NeuralSteps")))
    check(first in ("Starting", "Training") and paused == "Paused", "remote: trains in the background, pauses")
    check(nvtest.field_value(done, "NeuralSteps") == 400, "remote: resumed and finished at exactly 400 steps")
    Disconnect()

# The same pipeline in a built-in session: identical network (deterministic training) and image.
Connect()
LoadPlugin(nvtest.plugin_path(), remote=False, ns=globals())
local_png = os.path.join(out_dir, "ClientServer_builtin.png")
local = pipeline_and_render(local_png, False)
local_bytes = bytes(vtk_to_numpy(local.GetFieldData().GetArray("NeuralNetwork")))
# Training time differs between runs; everything else in the serialized model must match.
check(len(local_bytes) == len(remote_bytes), "same network size in both sessions")
local_field = vtk_to_numpy(local.GetPointData().GetArray("RTData"))
check(np.array_equal(local_field, remote_field), "client-server decoded field equals the built-in one")
check(nvtest.field_value(local, "NeuralPSNR") == remote_psnr, "same PSNR (%r vs %r)"
      % (nvtest.field_value(local, "NeuralPSNR"), remote_psnr))
remote_pixels = nvtest.read_png(remote_png)
check(float(np.mean(remote_pixels)) > 2.0, "the server rendered a non-blank image")
nvtest.compare_images(remote_png, local_png, 40.0, "client-server vs built-in render")
nvtest.finish()
