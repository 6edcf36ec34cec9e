"""NeuralVolume main job: compress a built-in volume (128^3 Wavelet), render it with the Neural Volume
representation, print training time, PSNR and compression ratio, and write an image.
usage: pvbatch Testing/demo.py PLUGIN.so [OUTPUT.png]"""
import sys
import time

from paraview.simple import *  # noqa: F401,F403 (pvbatch scripts must import paraview.simple)

plugin = sys.argv[1]
out = sys.argv[2] if len(sys.argv) > 2 else "neural_volume.png"
LoadPlugin(plugin, remote=False, ns=globals())

src = Wavelet(WholeExtent=[-63, 64, -63, 64, -63, 64])
nc = NeuralCompress(Input=src)
nc.SelectInputScalars = ["POINTS", "RTData"]
t0 = time.time()
nc.UpdatePipeline()  # returns at once: training runs in the background (TrainInBackground, the default)
started = time.time() - t0
state = servermanager.Fetch(nc).GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0)
nc.WaitForTraining()  # a script waits for the end; the GUI shows the network as it learns
nc.UpdatePipeline()
wall = time.time() - t0

fd = servermanager.Fetch(nc).GetFieldData()


def value(name):
    a = fd.GetAbstractArray(name)
    return a.GetValue(0) if a is not None else None


print("NeuralVolume demo: 128^3 Wavelet (RTData, float32, %.1f MB)" % (128 ** 3 * 4 / 1e6))
print("  device            %s" % value("NeuralDevice"))
print("  training steps    %d" % value("NeuralSteps"))
print("  training time     %.2f s (Apply returned after %.3f s in state %s; final after %.2f s)"
      % (value("NeuralTrainingSeconds"), started, state, wall))
print("  PSNR              %.2f dB (all voxels, values normalised by the data range)" % value("NeuralPSNR"))
print("  max error         %.4g" % value("NeuralMaxError"))
print("  compression ratio %.2f : 1 (%d model bytes)" % (value("NeuralCompressionRatio"), value("NeuralModelBytes")))

view = CreateRenderView()
view.ViewSize = [800, 800]
view.OrientationAxesVisibility = 0
view.Background = [0.1, 0.1, 0.15]
if hasattr(view, "UseColorPaletteForBackground"):
    view.UseColorPaletteForBackground = 0
rep = Show(nc, view)  # Neural Volume, coloured by RTData
lut = GetColorTransferFunction("RTData")
lut.ApplyPreset("Cool to Warm", True)
lo, hi = fd.GetArray("NeuralValueRange").GetValue(0), fd.GetArray("NeuralValueRange").GetValue(1)
pwf = GetOpacityTransferFunction("RTData")  # show the high values, let the low ones through
pwf.Points = [lo, 0.0, 0.5, 0.0, lo + 0.55 * (hi - lo), 0.0, 0.5, 0.0, hi, 0.8, 0.5, 0.0]
view.ResetCamera()
view.CameraPosition = [180, -260, 200]
view.CameraFocalPoint = [0, 0, 0]
view.CameraViewUp = [0, 0, 1]
view.ResetCamera()
Render(view)
SaveScreenshot(out, view, ImageResolution=[800, 800])


def info(name):
    rep.SMProxy.UpdatePropertyInformation()
    return rep.SMProxy.GetProperty(name).GetElement(0)


print("  render            %s path, %.1f ms for the last image, %d samples evaluated (a plain ray marcher: %d)"
      % (["Decode", "Sample Streaming", "In-Shader"][int(info("LastRenderPath"))], info("LastRenderMilliseconds"),
         info("LastSamplesEvaluated"), info("LastSamplesPlain")))
print("  image             %s" % out)
