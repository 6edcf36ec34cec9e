"""Neural Volume behaves like ParaView's own Volume: Neural Compress output is shown as Neural Volume coloured by
the network's array with a colour bar; switching to Neural Volume colours the same way (unless the user already
colours by an array, and without a bar when the settings say so); the panel shows the stock Volume Rendering group
and hides what the network renderer does not use; the engine's blend modes are offered; the stock representations
keep their behaviour."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()

from paraview.simple import *  # noqa: E402,F401,F403
import paraview.simple  # noqa: E402

nvtest.load_plugin(globals())
check, log, info = nvtest.check, nvtest.log, nvtest.info

paraview.simple._DisableFirstRenderCameraReset()
# Colour bars follow the general setting. Scripts run with manual colour bars; the GUI shows them automatically,
# as this test does first.
settings = GetSettingsProxy("GeneralSettings")
AUTOMATIC, MANUAL = "Automatically show and/or hide color bars", "Manual (not recommended)"
settings.ScalarBarMode = AUTOMATIC
wavelet, nc = nvtest.wavelet_network(half=15, TrainingSteps=60)
view = nvtest.render_view([200, 200])


def bar_shown(display):
    """Whether the colour bar of the display's map is visible (without creating one, unlike GetScalarBar)."""
    return display.SMProxy.IsScalarBarVisible(view.SMProxy)


# --- first Show ------------------------------------------------------------------------------------------
display = Show(nc, view)
check(display.Representation == "Neural Volume", "the default representation is Neural Volume (%r)"
      % display.Representation)
check(list(display.ColorArrayName) == ["POINTS", "RTData"], "coloured by the network's array on Show (%r)"
      % list(display.ColorArrayName))
lut = GetColorTransferFunction("RTData")
data_range = nc.PointData["RTData"].GetRange()
lut_range = (lut.RGBPoints[0], lut.RGBPoints[-4])
check(abs(lut_range[0] - data_range[0]) < 1e-3 and abs(lut_range[1] - data_range[1]) < 1e-3,
      "the colour map is fitted to the array's range (%r vs %r)" % (lut_range, data_range))
check(bar_shown(display), "the colour bar is shown")
Render(view)
check(info(display, "HasNetwork") == 1 and info(display, "EngineRenderCount") >= 1, "it renders the network")

# --- switching to Neural Volume ------------------------------------------------------------------------------
display.SetRepresentationType("Outline")
ColorBy(display, None)
HideScalarBarIfNotNeeded(lut, view)
check(not bar_shown(display), "no colour bar while solid-coloured")
display.SetRepresentationType("Neural Volume")
check(list(display.ColorArrayName) == ["POINTS", "RTData"], "switching to Neural Volume colours by the network")
check(bar_shown(display), "... with a colour bar")

# A colouring the user chose stays.
other = Calculator(Input=nc, ResultArrayName="Other", Function="RTData*2")
other_display = Show(other, view)
other_display.SetRepresentationType("Outline")
ColorBy(other_display, ("POINTS", "Other"))
other_display.SetRepresentationType("Neural Volume")
check(list(other_display.ColorArrayName) == ["POINTS", "Other"], "an existing colouring is kept (%r)"
      % list(other_display.ColorArrayName))
Hide(other, view)

# With manual colour bars (the scripts' setting) the colouring happens, the bar is left to the user.
settings.ScalarBarMode = MANUAL
display.SetRepresentationType("Outline")
ColorBy(display, None)
HideScalarBarIfNotNeeded(lut, view)
display.SetRepresentationType("Neural Volume")
check(list(display.ColorArrayName) == ["POINTS", "RTData"], "coloured with manual colour bars too")
check(not bar_shown(display), "no colour bar when colour bars are manual")
settings.ScalarBarMode = AUTOMATIC

# Other representation types are left alone.
display.SetRepresentationType("Outline")
ColorBy(display, None)
display.SetRepresentationType("Surface")
check(list(display.ColorArrayName)[1] == "", "Surface keeps the solid colour")
stock = Show(wavelet, view)
stock.SetRepresentationType("Volume")
check(list(stock.ColorArrayName) == ["POINTS", "RTData"], "the stock Volume still colours by itself")
Hide(wavelet, view)
display.SetRepresentationType("Neural Volume")

# --- the properties panel -----------------------------------------------------------------------------------
proxy = display.SMProxy


def decorators(element):
    """(property, value, inverse) of every GenericDecorator below an XML element."""
    found = []
    if element is None:
        return found
    if element.GetName() == "PropertyWidgetDecorator" and element.GetAttribute("type") == "GenericDecorator":
        found.append((element.GetAttribute("property"), element.GetAttribute("value"),
                      element.GetAttribute("inverse") == "1"))
    for i in range(element.GetNumberOfNestedElements()):
        found += decorators(element.GetNestedElement(i))
    return found


groups = {}
for i in range(proxy.GetNumberOfPropertyGroups()):
    group = proxy.GetPropertyGroup(i)
    if group.GetXMLLabel():
        groups[group.GetXMLLabel()] = group
check(("Representation", "Neural Volume", False) in decorators(groups["Volume Rendering"].GetHints()),
      "the stock Volume Rendering group is shown for Neural Volume")
check(("Representation", "Volume", False) in decorators(groups["Volume Rendering"].GetHints()),
      "... and still for Volume")
for label in ("Styling", "Scalar Coloring", "Miscellaneous"):
    check(("Representation", "Neural Volume", True) in decorators(groups[label].GetHints()),
          "the %s group is hidden for Neural Volume" % label)
for name in ("TransferFunction2D", "UseCropping", "VolumeRenderingMode", "IsosurfaceValues", "Luminosity",
             "Interpolation"):
    check(("Representation", "Neural Volume", True) in decorators(proxy.GetProperty(name).GetHints()),
          "%s is hidden for Neural Volume" % name)
for name in ("Shade", "BlendMode", "ScalarOpacityUnitDistance", "Specular", "SpecularPower", "Ambient", "Diffuse"):
    hints = proxy.GetProperty(name).GetHints()
    check(("Representation", "Neural Volume", True) not in decorators(hints), "%s is shown for Neural Volume" % name)
check(("ShadingMode", "3", False) in decorators(proxy.GetProperty("VolumeAnisotropy").GetHints()),
      "Volume Anisotropy is shown for path tracing")
for name in ("RenderPath", "ShadingMode", "SampleDistance", "StreamingSamples", "SamplesPerPixel", "MaxBounces",
             "TargetSamples", "Denoise", "FollowViewLight", "LightDirection", "EmptySpaceSkipping",
             "DecodeResolution", "InteractiveImageScale"):
    prop = proxy.GetProperty(name)
    check(prop is not None and prop.GetDocumentation() is not None, "%s is a documented property" % name)
import re  # noqa: E402
with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Cuda", "Core", "RenderSetup.h")) as f:
    engine_k = int(re.search(r"kDefaultStreamingSamples = (\d+)", f.read()).group(1))
check(display.StreamingSamples == engine_k, "StreamingSamples defaults to the engine's K (%d vs %d)"
      % (display.StreamingSamples, engine_k))

# --- blend modes the engine renders are offered -------------------------------------------------------------
domain = proxy.GetProperty("BlendMode").FindDomain("vtkSMEnumerationDomain")
entries = [domain.GetEntryText(i) for i in range(domain.GetNumberOfEntries())]
for text in ("Composite", "Maximum Intensity", "Minimum Intensity", "Average Intensity", "Additive"):
    check(text in entries, "blend mode %s offered (%r)" % (text, entries))
display.BlendMode = "Minimum Intensity"
Render(view)
check(display.GetPropertyValue("BlendMode") == "Minimum Intensity", "a new blend mode can be chosen")

nvtest.finish()
