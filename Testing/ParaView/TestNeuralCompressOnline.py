"""Online training with the filter's own defaults (background training, "Network only" output): the call returns
before training ends and the view's network changes between two renders; pause / resume / continue / fast-forward
step counts; stop; abort not sticky; Deterministic twice; output modes' sizes; a saved state restored in a new
process without a training step and with the identical decoded field."""
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()
import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

if len(sys.argv) > 2 and sys.argv[1] == "--restore":
    # Second process: load the state, count training steps, write the decoded field.
    nvtest.load_plugin(globals(), scripted=False)
    state, out_npy = sys.argv[2], sys.argv[3]
    start = time.time()
    LoadState(state)
    nc = FindSource("Online")
    nc.UpdatePipeline()
    seconds = time.time() - start
    nc.SMProxy.UpdatePropertyInformation()
    data = servermanager.Fetch(nc)
    np.save(out_npy, vtk_to_numpy(data.GetPointData().GetArray("RTData")))
    nvtest.log("restore: %.3f s, %d steps trained, state %s" % (
        seconds, nc.GetPropertyValue("TotalStepsTrained"),
        data.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0)))
    nvtest.check(nc.GetPropertyValue("TotalStepsTrained") == 0, "a restored state trains no step")
    nvtest.check(nvtest.field_value(data, "NeuralRestored") == 1, "NeuralRestored is 1")
    # The network array's range reaches ParaView's data information from the filter (not computed by VTK over the
    # network's bytes on every update) and is the true one.
    net_bytes = vtk_to_numpy(data.GetFieldData().GetArray("NeuralNetwork"))
    info = nc.GetDataInformation().DataInformation.GetFieldDataInformation().GetArrayInformation("NeuralNetwork")
    nvtest.check(info is not None and tuple(info.GetComponentRange(0)) == (float(net_bytes.min()), float(net_bytes.max())),
                 "the NeuralNetwork array's range in the data information is its bytes' range")
    # A script's still render returns the full grid's picture: decoded at once, or -- after an interactive render
    # left a coarse grid and a background decode -- that decode finished by the still render, to the same grid.
    view = nvtest.render_view([200, 200])
    display = Show(nc, view)
    display.Representation = "Neural Volume"
    display.DecodeResolution = [160, 160, 160]  # above the engine's progressive threshold (2^21 samples)
    view.ResetCamera()
    view.InteractiveRender()
    nvtest.check(nvtest.info(display, "WorkPending") == 1, "an interactive render shows a coarse grid first")
    Render(view)
    nvtest.check(nvtest.info(display, "WorkPending") == 0, "the still render that follows shows the full grid")
    helped = nvtest.read_png(nvtest.shot(view, os.path.join(nvtest.output_dir(), "online_restore_helped.png"), [200, 200]))
    display.DecodeResolution = [161, 161, 161]
    Render(view)
    display.DecodeResolution = [160, 160, 160]
    Render(view)
    nvtest.check(nvtest.info(display, "WorkPending") == 0, "a still render decodes the full grid at once")
    direct = nvtest.read_png(nvtest.shot(view, os.path.join(nvtest.output_dir(), "online_restore_direct.png"), [200, 200]))
    nvtest.check(np.array_equal(helped, direct) and helped.std() > 5.0,
                 "a background decode finished by a still render gives the directly decoded picture bit for bit")
    # The decoded field asked for after a render of the trained field's grid is that grid (copied, not decoded again)
    # and is the one decoded before any render.
    first = vtk_to_numpy(data.GetPointData().GetArray("RTData")).copy()
    display.DecodeResolution = [0, 0, 0]
    Render(view)
    nc.OutputMode = "Decoded, input type"
    start = time.time()
    nc.UpdatePipeline()
    again = vtk_to_numpy(servermanager.Fetch(nc).GetPointData().GetArray("RTData"))
    nvtest.log("decoded output after a render: %.3f s" % (time.time() - start))
    nvtest.check(np.array_equal(first, again), "the decoded field after a render is the one decoded before, bit for bit")
    nvtest.finish()
    nvtest._exit(0)  # this process has views now: no teardown (nvtest._exit)

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log
SMALL = dict(BatchSize=4096, Levels=8, FeaturesPerLevel=2, NetworkWidth=16, HiddenLayers=1, Loss="L2", Threads=2,
             TargetCompressionRatio=5)


def state_of(nc):
    data = servermanager.Fetch(nc)
    steps = nvtest.field_value(data, "NeuralSteps")  # none while the job's first network is being made
    return (data.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0),
            -1 if steps is None else int(steps), data)


wavelet = Wavelet(WholeExtent=[-31, 32] * 3)

# 1. The defaults: Apply returns at once, the network of the moment is shown, and it changes between renders.
nc = NeuralCompress(registrationName="Online", Input=wavelet, SelectInputScalars=["POINTS", "RTData"],
                    TrainingSteps=3000, TimeBudget=0, PSNRInterval=100, **SMALL)
check(nc.TrainInBackground == 1 and nc.OutputMode == "Network only", "defaults: background, network only")
start = time.time()
nc.UpdatePipeline()
returned = time.time() - start
state, steps, data = state_of(nc)
log("UpdatePipeline returned after %.3f s: %s at %d steps" % (returned, state, steps))
check(state in ("Starting", "Training", "Preparing") and steps < 3000, "the call returns before training ends (%s)" % state)
waited = time.time()
while state == "Preparing" and time.time() - waited < 10.0:
    # On a loaded machine the small network's first bytes may miss the execution that started its job.
    time.sleep(0.05)
    nc.SMProxy.GetClientSideObject().Modified()
    nc.SMProxy.MarkModified(nc.SMProxy)
    nc.UpdatePipeline()
    state, steps, data = state_of(nc)
check(state in ("Starting", "Training") and 0 <= steps < 3000, "a network while training (%s, %d steps)" % (state, steps))
check(data.GetPointData().GetNumberOfArrays() == 0, "Network only: no decoded array")
view = nvtest.render_view([240, 240])
display = Show(nc, view)
check(display.Representation == "Neural Volume", "shown as Neural Volume")
check(list(display.ColorArrayName) == ["POINTS", "RTData"], "coloured by the compressed array without a decoded field")
view.ResetCamera()
shots = []
for k in range(2):
    Render(view)
    path = os.path.join(nvtest.output_dir(), "online_%d.png" % k)
    SaveScreenshot(path, view, ImageResolution=[240, 240])
    shots.append(nvtest.read_png(path).astype(np.float64))
    time.sleep(1.5)
changed = np.mean(np.abs(shots[0] - shots[1]).max(axis=-1) > 2.0)
log("pixels changed between two renders while training: %.1f%%" % (100 * changed))
check(changed > 0.02, "the view's network changes between two renders while training")
check(shots[1].std() > 5.0, "the volume is drawn (not a blank view)")

# 2. Controls from Python.
nc.PauseTraining()
state, steps, _ = state_of(nc)
check(state == "Paused", "PauseTraining: state %s" % state)
time.sleep(0.3)
_, paused, _ = state_of(nc)
time.sleep(0.7)
nc.UpdatePipeline()
_, later, _ = state_of(nc)
check(later == paused, "paused: steps stay at %d (%d)" % (paused, later))
nc.ResumeTraining()
nc.WaitForTraining()
state, steps, data = state_of(nc)
check(state == "Finished" and steps == 3000, "resumed and finished at exactly 3000 steps (%s, %d)" % (state, steps))
psnr3000 = nvtest.field_value(data, "NeuralPSNR")
nc.ContinueSteps = 150
nc.ContinueTraining()
nc.WaitForTraining()
state, steps, data = state_of(nc)
check(state == "Finished" and steps == 3150, "ContinueTraining(150): 3150 steps (%s, %d)" % (state, steps))
nc.FastForward()
nc.WaitForTraining()
state, steps, data = state_of(nc)
check(steps == 4150, "FastForward: 1000 more steps (%d)" % steps)
check(nvtest.field_value(data, "NeuralPSNR") > psnr3000, "more steps, higher PSNR")
log_table = servermanager.Fetch(nc, idx=1)
check(log_table.GetNumberOfRows() == 4150, "the training log has a row per step (%d)" % log_table.GetNumberOfRows())
metrics = servermanager.Fetch(nc, idx=2)
check(metrics.GetNumberOfRows() == 1 and metrics.GetColumnByName("State").GetValue(0) == "Finished",
      "the metrics table: one row, Finished")

# 3. Stop: training no longer advances once the call returns.
long_run = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=10000000,
                          TimeBudget=0, **SMALL)
long_run.UpdatePipeline()
time.sleep(1.0)
start = time.time()
long_run.StopTraining()
long_run.UpdatePipeline()
state, stopped, _ = state_of(long_run)
latency = time.time() - start
log("stop: %s after %.3f s at %d steps" % (state, latency, stopped))
check(state in ("Stopped", "Finishing"), "StopTraining: the state says so at once (%s)" % state)
long_run.WaitForTraining()
state, final, data = state_of(long_run)
check(state == "Stopped" and final <= stopped + 1, "stopped: %s, %d steps after %d" % (state, final, stopped))
check(np.isfinite(nvtest.field_value(data, "NeuralPSNR")), "a stopped network is measured")

# 4. Abort is not sticky: an abort flag left on the filter does not cut the next execution short.
blocking = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=40,
                          TrainInBackground=0, **SMALL)
blocking.GetClientSideObject().SetAbortExecute(1)
blocking.UpdatePipeline()
check(state_of(blocking)[1] == 40, "an abort left set does not stop the next run")

# 5. Deterministic: the same network twice (decoded fields identical bit for bit), even with a tiny time budget.
decoded = []
for k in range(2):
    det = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=60, Deterministic=1,
                         TimeBudget=0.001, TrainInBackground=k, OutputMode="Decoded, float32", **SMALL)
    det.UpdatePipeline()
    det.WaitForTraining()
    det.UpdatePipeline()
    state, steps, data = state_of(det)
    check(steps == 60, "Deterministic ignores the time budget: 60 steps (%d)" % steps)
    decoded.append(vtk_to_numpy(data.GetPointData().GetArray("RTData")).copy())
check(np.array_equal(decoded[0], decoded[1]), "Deterministic: identical decoded fields, blocking and background")

# 6. Output modes: network only is smaller than the input; input type keeps int16; float32 doubles it.
short = Calculator(Input=wavelet, Function="RTData", ResultArrayName="Short", ResultArrayType="Short")
short.UpdatePipeline()
input_bytes = servermanager.Fetch(short).GetPointData().GetArray("Short").GetActualMemorySize()
sizes = {}
for mode in ("Network only", "Decoded, input type", "Decoded, float32"):
    out = NeuralCompress(Input=short, SelectInputScalars=["POINTS", "Short"], TrainingSteps=20, TrainInBackground=0,
                         OutputMode=mode, **SMALL)
    out.UpdatePipeline()
    data = servermanager.Fetch(out)
    array = data.GetPointData().GetArray("Short")
    sizes[mode] = (data.GetActualMemorySize(), array.GetDataTypeAsString() if array else None)
log("input array %d KiB; outputs %r" % (input_bytes, sizes))
check(sizes["Network only"][1] is None and sizes["Network only"][0] < input_bytes / 2,
      "network only: no array, under half the input's size")
check(sizes["Decoded, input type"][1] == "short", "decoded in the input's type (short)")
check(sizes["Decoded, float32"][1] == "float", "decoded in float32")
check(sizes["Decoded, input type"][0] < sizes["Decoded, float32"][0], "the input type is the smaller decoded output")

# 7. A saved state comes back in a new process without training, with the identical decoded field.
nc.OutputMode = "Decoded, float32"
nc.UpdatePipeline()
saved = vtk_to_numpy(servermanager.Fetch(nc).GetPointData().GetArray("RTData")).copy()
state_file = os.path.join(nvtest.output_dir(), "online.pvsm")
SaveState(state_file)
restored_npy = os.path.join(nvtest.output_dir(), "online_restored.npy")
if os.path.exists(restored_npy):
    os.remove(restored_npy)
pvbatch = os.environ.get("NV_PVBATCH", "pvbatch")
child = subprocess.run([pvbatch, "--force-offscreen-rendering", os.path.abspath(__file__), "--restore", state_file,
                        restored_npy], env=dict(os.environ), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       timeout=240)
log(child.stdout.decode(errors="replace").strip())
check(child.returncode == 0, "the restoring process passed its checks")
if os.path.exists(restored_npy):
    check(np.array_equal(np.load(restored_npy), saved), "the restored decoded field is the saved one bit for bit")
else:
    check(False, "the restoring process wrote the decoded field")

nvtest.finish()
