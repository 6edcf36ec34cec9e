"""Neural Volume on inputs it cannot render gives a clear error once and draws nothing, never a crash, and renders
again once the input is good: corrupt and truncated network bytes, a NeuralNetwork array of the wrong type, a
singular volume transform. Unusual but valid inputs render: a network of a cell array, a one-slice image."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
import paraview.simple  # noqa: E402
from vtkmodules.vtkCommonCore import vtkFloatArray, vtkUnsignedCharArray  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkImageData  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals())
check, log, info = nvtest.check, nvtest.log, nvtest.info
out_dir = nvtest.output_dir()
SIZE = [160, 160]

paraview.simple._DisableFirstRenderCameraReset()
wavelet, nc = nvtest.wavelet_network(half=15, TrainingSteps=60)
good = servermanager.Fetch(nc)
good_bytes = vtk_to_numpy(good.GetFieldData().GetArray("NeuralNetwork")).copy()
view = nvtest.render_view(SIZE)
lut = GetColorTransferFunction("RTData")
vmin, vmax = good.GetPointData().GetArray("RTData").GetRange()


def image_with_network(network_array):
    """The decoded Wavelet image with `network_array` (or none) as its NeuralNetwork field array."""
    image = vtkImageData()
    image.ShallowCopy(good)
    image.GetFieldData().Initialize()
    if network_array is not None:
        network_array.SetName("NeuralNetwork")
        image.GetFieldData().AddArray(network_array)
    producer = TrivialProducer()
    producer.GetClientSideObject().SetOutput(image)
    return producer


def bytes_array(values):
    array = numpy_to_vtk(np.ascontiguousarray(values, dtype=np.uint8), deep=1,
                         array_type=vtkUnsignedCharArray().GetDataType())
    return array


def show_neural(producer, label):
    display = Show(producer, view)
    ColorBy(display, ("POINTS", "RTData"))
    display.SetRepresentationType("Neural Volume")
    display.SetScalarBarVisibility(view, False)
    lut.RescaleTransferFunction(vmin, vmax)
    nvtest.set_camera(view, [55.0, -40.0, 75.0])
    return display


def render_and_capture(label):
    with nvtest.captured_messages() as messages:
        Render(view)
        Render(view)  # a second render must not repeat the error
    pixels = nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, "bad_%s.png" % label), SIZE))
    return messages[0], pixels


def expect_error(label, producer, phrase):
    display = show_neural(producer, label)
    text, pixels = render_and_capture(label)
    check(phrase in text and "ERROR" in text, "%s: error mentions %r (%r)" % (label, phrase, text))
    check(text.count("ERROR") == 1, "%s: reported once (%d times)" % (label, text.count("ERROR")))
    check(nvtest.is_uniform(pixels), "%s: nothing is drawn" % label)
    Hide(producer, view)
    return display


rng = np.random.default_rng(5)
expect_error("random bytes", image_with_network(bytes_array(rng.integers(0, 256, 4096))), "corrupt")
expect_error("truncated", image_with_network(bytes_array(good_bytes[:-100])), "corrupt")
flipped = good_bytes.copy()
flipped[len(flipped) // 2] ^= 0x40
expect_error("one byte changed", image_with_network(bytes_array(flipped)), "checksum")
wrong_type = vtkFloatArray()
wrong_type.SetNumberOfTuples(len(good_bytes))
expect_error("float array", image_with_network(wrong_type), "no 'NeuralNetwork' field data array")
expect_error("too short", image_with_network(bytes_array(good_bytes[:6])), "too short")

# --- a singular volume transform, then recovery ---------------------------------------------------------
display = show_neural(image_with_network(bytes_array(good_bytes)), "scaled")
display.Scale = [1.0, 1.0, 0.0]
text, pixels = render_and_capture("flattened")
check("singular" in text and "ERROR" in text, "a zero scale is an error (%r)" % text)
check(nvtest.is_uniform(pixels), "a zero scale draws nothing")
display.Scale = [1.0, 1.0, 1.0]
text, pixels = render_and_capture("recovered")
check("ERROR" not in text, "no error once the transform is valid (%r)" % text)
check(not nvtest.is_uniform(pixels), "it renders again")
check(info(display, "SessionFromBytes") == 1, "bytes without a live session are loaded")
Hide(display.Input, view)

# --- valid but unusual inputs -------------------------------------------------------------------------------
cells = PointDatatoCellData(Input=wavelet)
cell_network = NeuralCompress(Input=cells, SelectInputScalars=["CELLS", "RTData"], **dict(
    nvtest.WAVELET_NETWORK, TrainingSteps=60))
display = Show(cell_network, view)
display.SetScalarBarVisibility(view, False)
check(list(display.ColorArrayName) == ["CELLS", "RTData"], "a cell-array network is coloured by its cell array")
text, pixels = render_and_capture("cells")
check("ERROR" not in text and not nvtest.is_uniform(pixels), "a network of a cell array renders (%r)" % text)
Hide(cell_network, view)

flat = NeuralCompress(Input=Wavelet(WholeExtent=[-15, 16, -15, 16, 0, 0]), SelectInputScalars=["POINTS", "RTData"],
                      **dict(nvtest.WAVELET_NETWORK, TrainingSteps=60))
display = Show(flat, view)
display.SetScalarBarVisibility(view, False)
display.ScalarOpacityUnitDistance = 0.2
nvtest.set_camera(view, [0.5, 0.5, 80.0], up=[0.0, 1.0, 0.0])
text, pixels = render_and_capture("flat")
check("ERROR" not in text and not nvtest.is_uniform(pixels), "a one-slice network renders (%r)" % text)
Hide(flat, view)

# --- a field wider than the largest double: ParaView's colour maps abort on such a range (a Surface coloured by it
# aborts too), so the representation refuses it with an error instead of evaluating them ----------------------------
huge_field = Calculator(Input=Wavelet(WholeExtent=[-15, 16, -15, 16, -15, 16]), ResultArrayName="Huge",
                        Function="(RTData-157)*1.2e306", ResultArrayType="Double")
huge = NeuralCompress(Input=huge_field, SelectInputScalars=["POINTS", "Huge"],
                      **dict(nvtest.WAVELET_NETWORK, TrainingSteps=60))
display = Show(huge, view)  # not ColorBy: ParaView 5.11 aborts rescaling a colour map to such a range by itself
display.SetRepresentationType("Neural Volume")
display.SetScalarBarVisibility(view, False)
text, pixels = render_and_capture("huge_range")
check("wider than the largest double" in text and text.count("ERROR") == 1,
      "a range wider than the largest double is refused once (%r)" % text)
check(nvtest.is_uniform(pixels), "it draws nothing")
Hide(huge, view)

nvtest.finish()
