"""The Neural Volume representation: image against a committed baseline and against the stock
Volume representation of the source, progressive decoding, decode cache, shared color/opacity
maps, RenderPath fallback and an input without a network.

Set NV_GENERATE_BASELINE=1 to (re)write the baseline image instead of comparing with it."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()

from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
import paraview.simple  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
out_dir = nvtest.output_dir()
baseline_dir = os.environ.get("NV_BASELINE_DIR", os.path.join(os.path.dirname(__file__), "Baseline"))
BASELINE = os.path.join(baseline_dir, "TestNeuralVolumeRender.png")
SIZE = [300, 300]

# Thresholds (image PSNR, dB), measured on Mesa llvmpipe (Xvfb): neural vs baseline identical
# (inf), neural vs stock Volume 33.5 dB, partial (8 of 64 slices) vs full 12.9 dB.
BASELINE_DB = 40.0
STOCK_DB = 40.0
STOCK_DECODED_DB = 50.0
PARTIAL_MAX_DB = 25.0

wavelet = Wavelet(WholeExtent=[-31, 32, -31, 32, -31, 32])
wavelet.UpdatePipeline()
vmin, vmax = wavelet.PointData["RTData"].GetRange()
nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=800,
                    BatchSize=16384, Levels=12, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2,
                    Loss="L2", TargetCompressionRatio=5, Threads=2, PSNRInterval=0)
nc.UpdatePipeline()
log("training PSNR %.2f dB" % nvtest.field_value(servermanager.Fetch(nc), "NeuralPSNR"))

# The camera is placed explicitly; do not let the first simple.Render() reset it.
paraview.simple._DisableFirstRenderCameraReset()
view = CreateView("RenderView")
view.ViewSize = SIZE
view.OrientationAxesVisibility = 0
view.Background = [0.32, 0.34, 0.43]
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass

lut = GetColorTransferFunction("RTData")
lut.ApplyPreset("Cool to Warm", True)
pwf = GetOpacityTransferFunction("RTData")


def fix_maps():
    lut.RescaleTransferFunction(vmin, vmax)
    pwf.RescaleTransferFunction(vmin, vmax)
    lut.AutomaticRescaleRangeMode = "Never"


def place_camera():
    view.CameraPosition = [110.0, -80.0, 150.0]
    view.CameraFocalPoint = [0.5, 0.5, 0.5]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.CameraViewAngle = 30.0
    view.CameraParallelProjection = 0


def info(display, name):
    display.SMProxy.UpdatePropertyInformation()
    return display.SMProxy.GetProperty(name).GetElement(0)


def shot(name):
    path = os.path.join(out_dir, name)
    SaveScreenshot(path, view, ImageResolution=SIZE)
    return path


display = Show(nc, view)
ColorBy(display, ("POINTS", "RTData"))
display.SetRepresentationType("Neural Volume")
check(display.Representation == "Neural Volume", "representation type 'Neural Volume' is available")
check(display.LookupTable.SMProxy is lut.SMProxy, "the representation uses the RTData color map")
check(display.ScalarOpacityFunction.SMProxy is pwf.SMProxy, "... and its opacity map")
display.SlicesPerRender = 8
fix_maps()
place_camera()

# --- progressive decoding ---------------------------------------------------------------------
view.SMProxy.InteractiveRender()
check(info(display, "HasNetwork") == 1, "the input carries a network")
check(info(display, "TotalSlices") == 64, "decoded grid has the input's 64 slices")
check(info(display, "DecodedSlices") == 8, "an interactive render decodes SlicesPerRender slices (got %d)"
      % info(display, "DecodedSlices"))
Render(view)
check(info(display, "DecodedSlices") == 64, "a still render decodes the whole grid")
check(info(display, "DecodeCount") == 1, "one decode so far")

# Reset the progress by changing the resolution and back, then check two interactive steps.
display.DecodeResolution = [64, 64, 64]
view.SMProxy.InteractiveRender()
view.SMProxy.InteractiveRender()
check(info(display, "DecodedSlices") == 16, "two interactive renders decode 16 slices (got %d)"
      % info(display, "DecodedSlices"))
check(info(display, "DecodeCount") == 2, "a new DecodeResolution starts a new decode")
display.DecodeResolution = [0, 0, 0]
Render(view)
neural = shot("neural.png")
Render(view)
Render(view)
check(info(display, "DecodeCount") == 3, "re-rendering reuses the cached grid (decode count %d)"
      % info(display, "DecodeCount"))

display.DecodeResolution = [32, 32, 40]
Render(view)
check(info(display, "TotalSlices") == 40, "DecodeResolution sets the grid (%d slices)" % info(display, "TotalSlices"))
low = shot("neural_lowres.png")
display.DecodeResolution = [0, 0, 0]
Render(view)

# Partial image: an interactive render of a fresh decode shows only the first 8 slices.
display.DecodeResolution = [64, 64, 64]
view.SMProxy.InteractiveRender()
check(info(display, "DecodedSlices") == 8, "fresh decode, interactive: 8 slices")
from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter  # noqa: E402
from vtkmodules.vtkIOImage import vtkPNGWriter  # noqa: E402
w2i = vtkWindowToImageFilter()
w2i.SetInput(view.GetRenderWindow())
w2i.ReadFrontBufferOff()
w2i.ShouldRerenderOff()
w2i.Update()
writer = vtkPNGWriter()
partial = os.path.join(out_dir, "neural_partial.png")
writer.SetFileName(partial)
writer.SetInputConnection(w2i.GetOutputPort())
writer.Write()
# Drop the references to the render window now (a late release after the view is gone makes
# GLX fail at exit).
writer.SetInputConnection(None)
del writer, w2i
display.DecodeResolution = [0, 0, 0]
Render(view)

# --- baseline --------------------------------------------------------------------------------
if os.environ.get("NV_GENERATE_BASELINE"):
    import shutil
    os.makedirs(baseline_dir, exist_ok=True)
    shutil.copyfile(neural, BASELINE)
    log("baseline written to " + BASELINE)
else:
    nvtest.compare_images(neural, BASELINE, BASELINE_DB, "neural vs baseline")

partial_db = nvtest.image_psnr(nvtest.read_png(partial), nvtest.read_png(neural))
log("partial (8 slices) vs full: %.2f dB" % partial_db)
check(partial_db < PARTIAL_MAX_DB, "the partially decoded image differs from the full one")
check(nvtest.image_psnr(nvtest.read_png(low), nvtest.read_png(neural)) > 20.0,
      "a lower DecodeResolution renders a similar image")

# --- RenderPath fallback -------------------------------------------------------------------
with nvtest.captured_messages() as messages:
    display.RenderPath = "In-Shader"
    Render(view)
check("'In-Shader' render path arrives in a later version" in messages[0] and "Decode" in messages[0],
      "RenderPath In-Shader warns (%r)" % messages[0])
fallback = shot("neural_inshader.png")
check(nvtest.image_psnr(nvtest.read_png(fallback), nvtest.read_png(neural)) > 60.0,
      "In-Shader falls back to the Decode image")
display.RenderPath = "Decode"

# --- Volume Rendering Mode reaches the mapper of the decoded grid ----------------------------
display.VolumeRenderingMode = "Ray Cast Only"  # CPU ray caster instead of the GPU one
Render(view)
cpu = shot("neural_cpu_raycast.png")
cpu_db = nvtest.image_psnr(nvtest.read_png(cpu), nvtest.read_png(neural))
log("CPU ray cast vs GPU ray cast: %.2f dB" % cpu_db)
check(20.0 < cpu_db < 60.0, "VolumeRenderingMode switches the ray caster (similar, not identical image)")
display.VolumeRenderingMode = "Smart"

# --- shared color / opacity maps reach the neural mapper -------------------------------------
lut.ApplyPreset("Grayscale", True)
fix_maps()
Render(view)
gray = shot("neural_gray.png")
check(nvtest.image_psnr(nvtest.read_png(gray), nvtest.read_png(neural)) < 30.0,
      "changing the color map changes the neural image")
lut.ApplyPreset("Cool to Warm", True)
fix_maps()
display.ScalarOpacityUnitDistance = 0.5 * display.ScalarOpacityUnitDistance
Render(view)
denser = shot("neural_denser.png")
check(nvtest.image_psnr(nvtest.read_png(denser), nvtest.read_png(neural)) < 35.0,
      "ScalarOpacityUnitDistance reaches the neural mapper")
display.ScalarOpacityUnitDistance = 2.0 * display.ScalarOpacityUnitDistance

# --- stock Volume representation of the source, same maps -----------------------------------
Hide(nc, view)
stock_display = Show(wavelet, view)
ColorBy(stock_display, ("POINTS", "RTData"))
stock_display.SetRepresentationType("Volume")
stock_display.ScalarOpacityUnitDistance = display.ScalarOpacityUnitDistance
fix_maps()
place_camera()
Render(view)
stock = shot("stock.png")
nvtest.compare_images(neural, stock, STOCK_DB, "neural vs stock Volume of the source")

# The stock Volume representation of the decoded output (same values as the neural grid): only
# the rendering path differs, so the images must agree closely.
Hide(wavelet, view)
decoded_display = Show(nc, view)
decoded_display.SetRepresentationType("Volume")
ColorBy(decoded_display, ("POINTS", "RTData"))
decoded_display.ScalarOpacityUnitDistance = display.ScalarOpacityUnitDistance
fix_maps()
Render(view)
stock_decoded = shot("stock_decoded.png")
nvtest.compare_images(neural, stock_decoded, STOCK_DECODED_DB, "neural vs stock Volume of the decoded output")
Hide(nc, view)

# --- an image without a network -------------------------------------------------------------
with nvtest.captured_messages() as messages:
    bare = Show(wavelet, view)
    ColorBy(bare, ("POINTS", "RTData"))
    bare.SetRepresentationType("Neural Volume")
    Render(view)
check("no 'NeuralNetwork' field data array" in messages[0] and "ERROR" in messages[0],
      "an input without a network is an error (%r)" % messages[0])
check(info(bare, "HasNetwork") == 0, "HasNetwork is 0 without a network")
empty = nvtest.read_png(shot("no_network.png"))
check(float((empty.max(axis=(0, 1)) - empty.min(axis=(0, 1))).max()) <= 1.0,
      "nothing is rendered without a network (uniform background)")

nvtest.finish()
