"""Colour ranges on the default Network-only output (no decoded array, only the network and NeuralValueRange), over a
time series whose first step is constant: ParaView's Rescale to Data Range and its automatic rescale modes use the
network's range; the constant first step does not leave the later steps blank; the colouring box lists the array;
the training chart shows every step without errors; a cached step says so; the panel's status line (state, steps,
PSNR, time left); honest messages for Training Steps 0 and for a model larger than its field."""
import math
import os
import re
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from vtkmodules.vtkCommonDataModel import vtkImageData  # noqa: E402
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk  # noqa: E402

nvtest.require_display()
nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log

# A series written to disk: t=0 constant (a fluid at rest), then a blob that moves and grows (ranges 0..~0.05-0.1,
# as flow_demo_A's velocity magnitude).
N = 32
folder = os.path.join(nvtest.output_dir(), "colorrange")
os.makedirs(folder, exist_ok=True)
z, y, x = np.meshgrid(*(np.linspace(0.0, 1.0, N),) * 3, indexing="ij")
fields, entries = [], []
for t in range(4):
    if t == 0:
        field = np.zeros_like(x)
    else:
        cx = 0.3 + 0.1 * t
        field = 0.03 * t * np.exp(-((x - cx) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) / 0.04) \
            + 0.004 * np.sin(6 * y + t) ** 2
    field = field.astype(np.float32)
    fields.append(field)
    image = vtkImageData()
    image.SetDimensions(N, N, N)
    array = numpy_to_vtk(field.ravel(), deep=True)
    array.SetName("speed")
    image.GetPointData().SetScalars(array)
    copy = numpy_to_vtk(field.ravel(), deep=True)
    copy.SetName("flow")  # the same values under another name: a colour map of its own for a second filter
    image.GetPointData().AddArray(copy)
    writer = vtkXMLImageDataWriter()
    writer.SetFileName(os.path.join(folder, "step_%d.vti" % t))
    writer.SetInputData(image)
    writer.Write()
    entries.append('<DataSet timestep="%d" file="step_%d.vti"/>' % (t, t))
pvd = os.path.join(folder, "series.pvd")
with open(pvd, "w") as f:
    f.write('<?xml version="1.0"?><VTKFile type="Collection" version="0.1"><Collection>%s</Collection></VTKFile>'
            % "".join(entries))

NET = dict(BatchSize=8192, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2", Threads=2,
           TimeBudget=0, PSNRInterval=25, TargetCompressionRatio=2)
reader = PVDReader(FileName=pvd)
times = list(reader.TimestepValues)
check(times == [0.0, 1.0, 2.0, 3.0], "the series has 4 time steps (%r)" % times)
# The GUI's defaults: Network-only output, training in the background.
nc = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", "speed"], OutputMode="Network only",
                    TrainInBackground=1, TrainingSteps=150, **NET)

scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
scene.AnimationTime = times[0]
BACKGROUND = (0.0, 0.0, 0.0)
view = nvtest.render_view([160, 160], background=BACKGROUND)
SetActiveView(view)
display = Show(nc, view)
check(display.Representation == "Neural Volume", "Network-only output shown as Neural Volume")
check(display.ColorArrayName[1] == "speed", "coloured by the network's array (%r)" % (display.ColorArrayName,))
lut = GetColorTransferFunction("speed")
pwf = GetOpacityTransferFunction("speed")
view.CameraPosition = [N * 2.2, -N * 1.6, N * 1.3]
view.CameraFocalPoint = [N / 2.0] * 3
view.CameraViewUp = [0, 0, 1]
chart = CreateView("XYChartView")
chart.ViewSize = [300, 200]
log_display = Show(OutputPort(nc, 1), chart)


def lut_range():
    return lut.RGBPoints[0], lut.RGBPoints[-4]


def step_to(t):
    """What the GUI's time controls do (the animation scene updates the views and applies the rescale mode), then a
    render of the volume and of the training chart; returns the messages printed meanwhile."""
    with nvtest.captured_messages() as messages:
        scene.AnimationTime = t
        Render(view)
        Render(chart)
    return messages[0]


def drawn_pixels(label):
    """Pixels of the volume (the colour bars hidden) that differ from the background."""
    for name in ("speed", "flow"):
        GetScalarBar(GetColorTransferFunction(name), view).Visibility = 0
    path = nvtest.shot(view, os.path.join(nvtest.output_dir(), "colorrange_%s.png" % label), [160, 160])
    pixels = nvtest.read_png(path)
    return int(np.count_nonzero(np.abs(pixels - np.array(BACKGROUND) * 255.0).max(axis=2) > 8.0))


def network_range():
    out = nc.GetClientSideObject().GetOutputDataObject(0)
    return tuple(out.GetFieldData().GetArray("NeuralValueRange").GetValue(i) for i in range(2))


def close(a, b, rel=1e-6):
    return all(abs(p - q) <= rel * max(abs(p), abs(q), 1e-30) for p, q in zip(a, b))


# --- The constant first step: ParaView's range of a single value, no error, nothing to draw (all at the low end).
messages = step_to(times[0])
check("ERR" not in messages and "Could not determine" not in messages, "t=0: no error (%s)" % messages.strip())
lo0, hi0 = lut_range()
log("t=0 (constant 0): colour range %r, network range %r" % ((lo0, hi0), network_range()))
check(network_range() == (0.0, 0.0), "t=0: the network's range is the constant")
check(lo0 == 0.0 and 0.0 < hi0 < 1e-30, "t=0: the colour range is ParaView's widened constant (%r, %r)" % (lo0, hi0))
pixels = drawn_pixels("t0")
log("t=0: %d pixels drawn" % pixels)
check(pixels < 50, "t=0: a constant field at the low end of its range is transparent (%d pixels drawn)" % pixels)

# --- Later steps train, draw, and Rescale to Data Range gives the network's range ----------------------------------
status_pattern = re.compile(r"^(\w+): (\d+)/(\d+) steps, PSNR ([0-9.]+) dB")
for i, t in enumerate(times[1:], start=1):
    messages = step_to(t)  # the training starts: the view and the chart show its first networks
    nc.WaitForTraining()
    messages += step_to(t)
    numpy_range = (float(fields[i].min()), float(fields[i].max()))
    net = network_range()
    pixels = drawn_pixels("t%d" % i)
    log("t=%g: network range %r, numpy %r, colour range %r, %d pixels drawn"
        % (t, net, numpy_range, lut_range(), pixels))
    check(pixels > 800, "t=%g: the picture is not empty (%d pixels drawn)" % (t, pixels))
    check("Attempted to paint a line" not in messages and "ERR" not in messages,
          "t=%g: no error from the training chart or the renderer (%s)" % (t, messages.strip()))
    check(close(net, numpy_range), "t=%g: NeuralValueRange is the step's range %r (%r)" % (t, numpy_range, net))
    if i == 1:
        check(close(lut_range(), net), "t=1: the first step with a range replaces the constant step's colour range")
    with nvtest.captured_messages() as rescale:
        ok = display.RescaleTransferFunctionToDataRange(False, True)
    check(ok and "Could not determine" not in rescale[0], "t=%g: Rescale to Data Range succeeds (%s)"
          % (t, rescale[0].strip()))
    check(close(lut_range(), net) and close((pwf.Points[0], pwf.Points[-4]), net),
          "t=%g: Rescale to Data Range gives the network's range %r (colour %r)" % (t, net, lut_range()))
    nc.SMProxy.UpdatePropertyInformation()
    status = nc.GetPropertyValue("TrainingStatus")
    match = status_pattern.match(status)
    check(match is not None and match.group(1) == "Finished" and match.group(2) == match.group(3) == "150" and
          abs(float(match.group(4)) - nvtest.field_value(nc.GetClientSideObject().GetOutputDataObject(0),
                                                          "NeuralPSNR")) < 0.01,
          "t=%g: the status line says state, steps and PSNR (%r)" % (t, status))

# The colouring box lists the network's array (no "speed (?)"): ParaView's array list of the representation has it.
domain = display.SMProxy.GetProperty("ColorArrayName").FindDomain("vtkSMArrayListDomain")
names = [domain.GetString(i) for i in range(domain.GetNumberOfStrings())]
check("speed" in names, "the colouring box lists 'speed' (%r)" % names)

# --- ParaView's automatic modes on time steps ------------------------------------------------------------------------
lut.AutomaticRescaleRangeMode = "Clamp and update every timestep"
for i in (2, 1, 3):
    step_to(times[i])
    check(close(lut_range(), network_range()), "Clamp and update every timestep, t=%g: %r is the network's %r"
          % (times[i], lut_range(), network_range()))
lut.AutomaticRescaleRangeMode = "Grow and update every timestep"
lut.RescaleTransferFunction(0.0, 0.001)
union = (0.0, 0.0)
for i in (1, 3, 2):
    step_to(times[i])
    union = (min(union[0], network_range()[0]), max(union[1], network_range()[1]))
    check(close(lut_range(), union), "Grow and update every timestep, t=%g: %r grows to %r"
          % (times[i], lut_range(), union))
lut.AutomaticRescaleRangeMode = "Grow and update on 'Apply'"

# --- Cached steps say so; a locked range is left alone ---------------------------------------------------------------
nc.SMProxy.UpdatePropertyInformation()
trained = nc.GetPropertyValue("TotalStepsTrained")
messages = step_to(times[1])
nc.SMProxy.UpdatePropertyInformation()
out = nc.GetClientSideObject().GetOutputDataObject(0)
status = nc.GetPropertyValue("TrainingStatus")
log("back to t=1: %r; %s" % (status, messages.strip()))
check(nc.GetPropertyValue("TotalStepsTrained") == trained, "stepping back trains nothing")
check(nvtest.field_value(out, "NeuralFromCache") == 1, "NeuralFromCache says the network came from the cache")
check(status.startswith("Cached: 150 steps") and "trained before in" in status,
      "the status line says cached (%r)" % status)
check("taken from the cache" in messages and not re.search(r": 150 steps in [0-9.]+ s on", messages.split("(")[0]),
      "the message says the network came from the cache (%s)" % messages.strip())
lut.AutomaticRescaleRangeMode = "Never"
lut.RescaleTransferFunction(0.0, 1e-38)
step_to(times[2])
check(lut_range() == (0.0, 1e-38), "a locked (Never) colour range is not changed by a time step (%r)" % (lut_range(),))
lut.AutomaticRescaleRangeMode = "Grow and update on 'Apply'"

# --- A constant first step seen by a fresh filter (a colour map of its own) in the default mode: later steps draw --
Delete(display)
fresh = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", "flow"], OutputMode="Network only",
                       TrainingSteps=150, **NET)
scene.AnimationTime = times[0]
fresh_display = Show(fresh, view)
Render(view)
flow_lut = GetColorTransferFunction("flow")
flow_range = lambda: (flow_lut.RGBPoints[0], flow_lut.RGBPoints[-4])  # noqa: E731
check(flow_lut.AutomaticRescaleRangeMode == "Grow and update on 'Apply'", "the default rescale mode")
check(flow_range()[1] < 1e-30, "fresh filter at t=0: the constant step's range (%r)" % (flow_range(),))
for i in (2, 3):
    step_to(times[i])
    fresh_range = tuple(fresh.GetClientSideObject().GetOutputDataObject(0).GetFieldData().GetArray(
        "NeuralValueRange").GetValue(k) for k in range(2))
    pixels = drawn_pixels("fresh_t%d" % i)
    log("fresh filter, t=%d: colour range %r, network %r, %d pixels" % (i, flow_range(), fresh_range, pixels))
    # The first step with a range replaces the constant step's; the next keeps it (Grow and update on Apply).
    check(close(flow_range(), fresh_range) if i == 2 else flow_range()[1] > 0.05,
          "fresh filter, t=%d after the constant step: a usable range (%r)" % (i, flow_range()))
    check(pixels > 800, "fresh filter, t=%d after the constant step: the picture is not empty (%d pixels)"
          % (i, pixels))
Delete(fresh_display)
Delete(fresh)

# --- Background training: the status line has the time left ----------------------------------------------------------
wavelet = Wavelet(WholeExtent=[-15, 16] * 3)
live = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], OutputMode="Network only",
                      TrainInBackground=1, TrainingSteps=1000000, **NET)
live.UpdatePipeline()
status = ""
for attempt in range(20):  # the first step can take a moment on a loaded machine
    time.sleep(0.5)
    live.GetClientSideObject().Modified()  # as ParaView's live-source timer does when a newer network is there
    live.UpdatePipeline(0.0)
    live.SMProxy.UpdatePropertyInformation()
    status = live.GetPropertyValue("TrainingStatus")
    if attempt >= 3 and " s left" in status:
        break
log("background training: %r" % status)
match = re.match(r"^Training: (\d+)/1000000 steps, PSNR ([0-9.]+) dB \(estimate\), ([0-9.]+) s, about ([0-9.]+) s left",
                 status)
check(match is not None and int(match.group(1)) > 0, "the status line while training: state, steps, PSNR, time left "
      "(%r)" % status)
live.StopTraining()
live.WaitForTraining()

# --- Honest messages ---------------------------------------------------------------------------------------------------
for steps in (0, -5):
    with nvtest.captured_messages() as messages:
        untrained = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=steps, **NET)
        untrained.UpdatePipeline()
    untrained.SMProxy.UpdatePropertyInformation()
    status = untrained.GetPropertyValue("TrainingStatus")
    log("TrainingSteps %d: %r; %s" % (steps, status, messages[0].strip()))
    check("constant" not in messages[0] and "constant" not in status,
          "TrainingSteps %d: no '(constant field)' for a field that is not constant" % steps)
    check("Training Steps is 0" in messages[0] and "Training Steps is 0" in status,
          "TrainingSteps %d: the message and the status say the network is untrained" % steps)
    Delete(untrained)

constant = nvtest.point_image(np.full((8, 8, 8), 2.5), (8, 8, 8), "c")
with nvtest.captured_messages() as messages:
    flat = NeuralCompress(Input=constant, SelectInputScalars=["POINTS", "c"], **NET)
    flat.UpdatePipeline()
check("(constant field)" in messages[0], "a constant field still says so (%s)" % messages[0].strip())

small = nvtest.point_image(np.random.default_rng(1).random((8, 8, 8)).astype(np.float32), (8, 8, 8), "s")
with nvtest.captured_messages() as messages:
    tiny = NeuralCompress(Input=small, SelectInputScalars=["POINTS", "s"], TrainingSteps=20,
                          **dict(NET, TargetCompressionRatio=0))
    tiny.UpdatePipeline()
tiny.SMProxy.UpdatePropertyInformation()
ratio = nvtest.field_value(tiny.GetClientSideObject().GetOutputDataObject(0), "NeuralCompressionRatio")
status = tiny.GetPropertyValue("TrainingStatus")
log("8^3 float32 field: ratio %.3f:1; %r; %s" % (ratio, status, messages[0].strip()))
check(ratio < 1.0, "an 8^3 field is smaller than the model (ratio %.3f)" % ratio)
check("larger than the field" in messages[0] and "smaller model" in messages[0] and "Features Per Level" in messages[0],
      "a ratio below 1:1 comes with advice (%s)" % messages[0].strip())
check("model larger than the field" in status, "the status line says the model is larger (%r)" % status)

# A run of one step: its log of one row stays empty, and its chart draws without error.
one = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=1, **NET)
one.UpdatePipeline()
check(one.GetClientSideObject().GetOutputDataObject(1).GetNumberOfRows() == 0, "a log of one step has no rows")
with nvtest.captured_messages() as messages:
    Show(OutputPort(one, 1), chart)
    Render(chart)
check("Attempted to paint a line" not in messages[0], "a one-step log charts without error (%s)" % messages[0].strip())

nvtest.finish()
