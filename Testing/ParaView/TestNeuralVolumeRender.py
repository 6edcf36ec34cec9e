"""The Neural Volume representation renders the network through the engine: image against a committed baseline and
against the stock Volume representation of the decoded output, the filter's own session reused, no engine render
while nothing changes, the reduced interactive render, colour/opacity maps and volume properties reaching the
engine at once, blend modes, a session loaded from saved bytes, and an input without a network.

Set NV_GENERATE_BASELINE=1 to (re)write the baseline image instead of comparing with it."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()

from paraview.simple import *  # noqa: E402,F401,F403
import paraview.simple  # noqa: E402

nvtest.load_plugin(globals())
check, log, info = nvtest.check, nvtest.log, nvtest.info
out_dir = nvtest.output_dir()
SIZE = [300, 300]

# Thresholds (image PSNR, dB). The Decode path samples the decoded grid trilinearly like the stock GPU ray caster
# samples the decoded output, with the same maps: measured 49.1 dB (CPU engine; Mesa llvmpipe, Xvfb).
BASELINE_DB = 40.0
STOCK_DECODED_DB = 36.0
SAME_DB = 60.0        # a render that must reproduce an earlier one
CHANGED_MAX_DB = 35.0  # a change of the maps or properties must show

paraview.simple._DisableFirstRenderCameraReset()
wavelet, nc = nvtest.wavelet_network()
vmin, vmax = wavelet.PointData["RTData"].GetRange()
view = nvtest.render_view(SIZE)
lut = GetColorTransferFunction("RTData")
pwf = GetOpacityTransferFunction("RTData")


def fix_maps(preset="Cool to Warm"):
    lut.ApplyPreset(preset, True)
    lut.RescaleTransferFunction(vmin, vmax)
    pwf.RescaleTransferFunction(vmin, vmax)
    lut.AutomaticRescaleRangeMode = "Never"


def place_camera():
    nvtest.set_camera(view, [110.0, -80.0, 150.0])


def shot(name):
    return nvtest.shot(view, os.path.join(out_dir, name), SIZE)


def psnr(a, b):
    return nvtest.image_psnr(nvtest.read_png(a), nvtest.read_png(b))


display = Show(nc, view)
display.SetScalarBarVisibility(view, False)
check(display.Representation == "Neural Volume", "Neural Compress output is shown as Neural Volume")
check(display.LookupTable.SMProxy is lut.SMProxy, "the representation uses the RTData colour map")
fix_maps()
place_camera()
Render(view)
check(info(display, "HasNetwork") == 1, "the input carries a network")
check(info(display, "SessionFromBytes") == 0, "the renderer uses the session the filter trained (no reload)")
check(info(display, "LastRenderPath") == 0, "Decode is the default path and the engine ran it")
check(info(display, "LastImageSize") == SIZE, "a still render is full size (%r)" % info(display, "LastImageSize"))
check(info(display, "LastSamplesEvaluated") > 0, "the engine evaluated samples")
check(info(display, "WorkPending") == 0, "a still render in a script returns the final picture")
neural = shot("neural.png")
nvtest.baseline(neural, "TestNeuralVolumeRender", BASELINE_DB, "neural vs baseline")

# --- no engine render while nothing changes ----------------------------------------------------
renders = info(display, "EngineRenderCount")
Render(view)
Render(view)
check(info(display, "EngineRenderCount") == renders, "unchanged re-renders reuse the image (%d -> %d engine renders)"
      % (renders, info(display, "EngineRenderCount")))
check(psnr(shot("neural_again.png"), neural) >= SAME_DB, "the reused image is the same picture")

# --- interactive render: reduced image ---------------------------------------------------------
view.SMProxy.InteractiveRender()
check(info(display, "LastImageSize") == [150, 150], "an interactive render is half size by default (%r)"
      % info(display, "LastImageSize"))
display.InteractiveImageScale = 0.25
view.SMProxy.InteractiveRender()
check(info(display, "LastImageSize") == [75, 75], "InteractiveImageScale 0.25 (%r)" % info(display, "LastImageSize"))
before = info(display, "EngineRenderCount")
Render(view)
check(info(display, "EngineRenderCount") == before + 1 and info(display, "LastImageSize") == SIZE,
      "the still render after interaction renders full size again")
display.InteractiveImageScale = 0.5

# --- a large decode grid: the CPU engine decodes it progressively for interaction; a script's still render decodes
# the full grid at once on all the session's threads (no coarse frame), and after an interactive render that left a
# coarse grid it finishes the background decode ------------------------------------------------------------------
before = info(display, "EngineRenderCount")
display.DecodeResolution = [160, 160, 160]
Render(view)
check(info(display, "EngineRenderCount") == before + 1, "the still render decoded the full grid at once "
      "(%d engine renders)" % (info(display, "EngineRenderCount") - before))
check(info(display, "WorkPending") == 0, "... and returned the final picture")
fine = shot("neural_decode160.png")
check(psnr(fine, neural) >= 30.0, "a finer decode grid renders the same volume (%.1f dB)" % psnr(fine, neural))
display.DecodeResolution = [161, 161, 161]
view.SMProxy.InteractiveRender()
check(info(display, "WorkPending") == 1, "an interactive render shows a coarse grid while the full one decodes")
Render(view)
check(info(display, "WorkPending") == 0, "the still render that follows finishes that decode: the final picture")
display.DecodeResolution = [0, 0, 0]
Render(view)

# --- colour and opacity maps reach the engine at once -------------------------------------------
before = info(display, "EngineRenderCount")
fix_maps("Grayscale")
Render(view)
check(info(display, "EngineRenderCount") == before + 1, "a colour map change renders again")
gray = shot("neural_gray.png")
check(psnr(gray, neural) < CHANGED_MAX_DB, "the colour map change shows (%.1f dB)" % psnr(gray, neural))
fix_maps()
pwf.Points = [vmin, 0.0, 0.5, 0.0, 0.5 * (vmin + vmax), 0.0, 0.5, 0.0, vmax, 0.6, 0.5, 0.0]
Render(view)
opacity = shot("neural_opacity.png")
check(psnr(opacity, neural) < CHANGED_MAX_DB, "the opacity map change shows (%.1f dB)" % psnr(opacity, neural))
pwf.Points = [vmin, 0.0, 0.5, 0.0, vmax, 1.0, 0.5, 0.0]
fix_maps()
Render(view)
check(psnr(shot("neural_restored.png"), neural) >= SAME_DB, "restoring the maps restores the picture")

unit = display.ScalarOpacityUnitDistance
display.ScalarOpacityUnitDistance = 0.25 * unit
Render(view)
denser = shot("neural_denser.png")
check(psnr(denser, neural) < CHANGED_MAX_DB, "ScalarOpacityUnitDistance reaches the engine (%.1f dB)"
      % psnr(denser, neural))
display.ScalarOpacityUnitDistance = unit

# --- Shade (gradient shading) and the lighting coefficients ------------------------------------
display.Shade = 1
display.Ambient = 0.2
display.Diffuse = 0.8
Render(view)
shaded = shot("neural_shaded.png")
check(psnr(shaded, neural) < CHANGED_MAX_DB, "Shade renders with gradient shading (%.1f dB)" % psnr(shaded, neural))
display.Specular = 0.8
Render(view)
check(psnr(shot("neural_specular.png"), shaded) < 50.0, "Specular reaches the engine")
display.Shade = 0
display.Specular = 0.0
display.Ambient = 0.0
display.Diffuse = 1.0

# --- blend modes ---------------------------------------------------------------------------------
display.BlendMode = "Maximum Intensity"
Render(view)
mip = shot("neural_mip.png")
check(psnr(mip, neural) < CHANGED_MAX_DB, "Maximum Intensity blending renders its own picture")
with nvtest.captured_messages() as messages:
    display.BlendMode = "Isosurface"
    Render(view)
check("Isosurface blend mode is not available" in messages[0], "Isosurface warns (%r)" % messages[0])
check(psnr(shot("neural_iso.png"), neural) >= SAME_DB, "... and renders Composite")
display.BlendMode = "Composite"

# --- the stock Volume representation of the decoded output (same values, same maps) -------------
Render(view)
display.SetRepresentationType("Volume")
Render(view)
stock = shot("stock_decoded.png")
nvtest.compare_images(neural, stock, STOCK_DECODED_DB, "neural vs stock Volume of the decoded output")
display.SetRepresentationType("Neural Volume")

# --- a session from the bytes: the network saved to a file and read back --------------------------
vti = os.path.join(out_dir, "neural_network.vti")
SaveData(vti, proxy=nc, ChooseArraysToWrite=1, PointDataArrays=["RTData"], FieldDataArrays=["NeuralNetwork"])
Hide(nc, view)
reader = XMLImageDataReader(FileName=[vti])
loaded = Show(reader, view)
check(loaded.Representation in ("Outline", "Neural Volume"), "the saved image shows (%r)" % loaded.Representation)
loaded.SetRepresentationType("Neural Volume")
check(list(loaded.ColorArrayName) == ["POINTS", "RTData"], "switching to Neural Volume colours by the network")
loaded.SetScalarBarVisibility(view, False)
fix_maps()
Render(view)
check(info(loaded, "SessionFromBytes") == 1, "a network without a live session is loaded from its bytes")
reloaded = shot("neural_reloaded.png")
check(psnr(reloaded, neural) >= SAME_DB, "the reloaded network renders the same picture (%.1f dB)"
      % psnr(reloaded, neural))
Hide(reader, view)

# --- an image without a network --------------------------------------------------------------------
with nvtest.captured_messages() as messages:
    bare = Show(wavelet, view)
    ColorBy(bare, ("POINTS", "RTData"))
    bare.SetRepresentationType("Neural Volume")
    Render(view)
check("no 'NeuralNetwork' field data array" in messages[0] and "ERROR" in messages[0],
      "an input without a network is an error (%r)" % messages[0])
check(info(bare, "HasNetwork") == 0, "HasNetwork is 0 without a network")
check(nvtest.is_uniform(nvtest.read_png(shot("no_network.png"))), "nothing is rendered without a network")

nvtest.finish()
