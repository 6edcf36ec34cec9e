"""State file round trip: SaveState, ResetSession, LoadState restores the Neural Compress filter
and the Neural Volume representation properties, and renders the same image."""
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
STATE = os.path.join(out_dir, "neural_state.pvsm")
SIZE = [300, 300]
SAME_DB = 45.0  # training is deterministic (fixed seed and threads): measured inf

FILTER_PROPS = dict(TrainingSteps=200, BatchSize=8192, Levels=8, FeaturesPerLevel=2, NetworkWidth=32,
                    HiddenLayers=2, Loss="L2", Threads=2, Seed=7, PSNRInterval=25,
                    TargetCompressionRatio=1.5, StoragePrecision="Float32")
DISPLAY_PROPS = dict(RenderPath="In-Shader", ShadingMode="Ray Marching + Shadows", SampleDistance=0.7,
                     StreamingSamples=4, DecodeResolution=[24, 28, 20], SamplesPerPixel=2, TargetSamples=6,
                     MaxBounces=3, FollowViewLight=0, LightDirection=[1.0, 0.0, 0.5], EmptySpaceSkipping=0,
                     InteractiveImageScale=0.3)

paraview.simple._DisableFirstRenderCameraReset()
wavelet = Wavelet(WholeExtent=[-15, 16, -15, 16, -15, 16])
nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], **FILTER_PROPS)
RenameSource("NeuralRoundTrip", nc)
view = CreateView("RenderView")
view.ViewSize = SIZE
view.OrientationAxesVisibility = 0
display = Show(nc, view)
ColorBy(display, ("POINTS", "RTData"))
display.SetRepresentationType("Neural Volume")
for key, value in DISPLAY_PROPS.items():
    setattr(display, key, value)
lut = GetColorTransferFunction("RTData")
lut.ApplyPreset("Rainbow Uniform", True)
lut.RescaleTransferFunction(40.0, 260.0)
GetOpacityTransferFunction("RTData").RescaleTransferFunction(40.0, 260.0)
view.CameraPosition = [60.0, -45.0, 70.0]
view.CameraFocalPoint = [0.5, 0.5, 0.5]
view.CameraViewUp = [0.0, 0.0, 1.0]
Render(view)
before = os.path.join(out_dir, "state_before.png")
SaveScreenshot(before, view, ImageResolution=SIZE)
psnr_before = nvtest.field_value(servermanager.Fetch(nc), "NeuralPSNR")

SaveState(STATE)
text = open(STATE).read()
check("Neural Volume" in text and "DecodeResolution" in text and 'type="NeuralCompress"' in text,
      "the state file records the filter and the representation")
check("ProgressiveRefinement" not in text, "the GUI-only ProgressiveRefinement is not saved")

ResetSession()
check(FindSource("NeuralRoundTrip") is None, "session reset")
paraview.simple._DisableFirstRenderCameraReset()
LoadState(STATE)

nc2 = FindSource("NeuralRoundTrip")
check(nc2 is not None, "filter restored from the state file")
views = GetRenderViews()
check(len(views) == 1, "one render view restored")
view2 = views[0]
view2.ViewSize = SIZE
display2 = GetDisplayProperties(nc2, view=view2)
check(display2.Representation == "Neural Volume", "representation restored (%r)" % display2.Representation)
for key, value in FILTER_PROPS.items():
    actual = nc2.GetPropertyValue(key)
    check(actual == value or actual == str(value), "filter %s restored (%r)" % (key, actual))
check(list(nc2.SelectInputScalars) == ["POINTS", "RTData"], "input array restored")
for key, value in DISPLAY_PROPS.items():
    actual = display2.GetPropertyValue(key)
    actual = list(actual) if isinstance(value, list) else actual
    check(actual == value, "display %s restored (%r)" % (key, actual))
check(list(display2.ColorArrayName) == ["POINTS", "RTData"], "coloring restored")
lut2 = GetColorTransferFunction("RTData")
check((lut2.RGBPoints[0], lut2.RGBPoints[-4]) == (40.0, 260.0),
      "the saved colour map range is kept (not refitted on load): %r" % ((lut2.RGBPoints[0], lut2.RGBPoints[-4]),))

Render(view2)
after = os.path.join(out_dir, "state_after.png")
SaveScreenshot(after, view2, ImageResolution=SIZE)
check(nvtest.info(display2, "LastRenderPath") == 2, "the restored In-Shader path renders")
check(nvtest.info(display2, "LastImageSize") == SIZE, "full-size still render after loading")
psnr_after = nvtest.field_value(servermanager.Fetch(nc2), "NeuralPSNR")
check(psnr_after == psnr_before, "re-training after LoadState is deterministic (%r vs %r)"
      % (psnr_before, psnr_after))
nvtest.compare_images(after, before, SAME_DB, "after LoadState vs before SaveState")

nvtest.finish()
