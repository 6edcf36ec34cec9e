"""NeuralVolume main job: compress a 256^3 Mandelbulb with Neural Compress, render it with ParaView's Volume and with
the Neural Volume representation, and write one picture: original | Neural Volume | error, with the training time,
PSNR and compression ratio, and the PSNR over the training time.

usage: pvbatch Testing/demo.py PLUGIN.so [OUTPUT.png] [--size N] [--budget SECONDS] [--steps N] [--panels DIR]
The last line printed is "demo figures: {...}" (JSON: psnr, ratio, seconds, steps, ...), read by the CI test."""
import argparse
import json
import os
import sys
import tempfile
import time

from paraview import servermanager
from paraview.simple import *  # noqa: F401,F403 (pvbatch scripts must import paraview.simple)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import demo_picture  # noqa: E402
import demo_volume  # noqa: E402

# Neural Compress settings, chosen for 2 CPU cores and a minute: a hash grid of 16 levels x 2 features (the table sized
# for a ratio of 20:1 or more) and a 2 x 32 ReLU MLP, L2 loss (what PSNR measures), batches of 32768 voxels; a PSNR
# estimate every 25 steps for the chart.
NETWORK = dict(TargetCompressionRatio=20, Levels=16, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2,
               BatchSize=32768, Loss="L2", LearningRate=0.005, LearningRateSchedule="Constant", PSNRInterval=25)
CAMERA = dict(CameraFocalPoint=[0.0, 0.0, 0.0], CameraPosition=[2.6, -3.4, 2.2], CameraViewUp=[0.0, 0.0, 1.0],
              CameraViewAngle=30.0)


def say(text):
    print(text)
    sys.stdout.flush()


def field_figure(data, name):
    a = data.GetFieldData().GetAbstractArray(name)
    if a is None or a.GetNumberOfTuples() < 1:
        return None
    v = a.GetVariantValue(0)
    return v.ToString() if a.IsA("vtkStringArray") else v.ToDouble()


def mandelbulb_source(n):
    """The n^3 Mandelbulb (numpy, so the demo needs no data set) as a ParaView source (a trivial producer)."""
    from vtkmodules.vtkCommonDataModel import vtkImageData
    image = vtkImageData()
    demo_volume.fill(image, n)
    volume = PVTrivialProducer()
    volume.GetClientSideObject().SetOutput(image)
    volume.UpdatePipeline()
    return volume


def compress(volume, budget, steps):
    """Neural Compress of the volume (blocking, decoded float32 output for the error map) and its figures."""
    network = NeuralCompress(Input=volume, SelectInputScalars=["POINTS", demo_volume.ARRAY],
                             TrainInBackground=0, OutputMode="Decoded, float32",
                             TrainingSteps=steps, TimeBudget=budget, **NETWORK)
    start = time.time()
    network.UpdatePipeline()
    decoded = servermanager.Fetch(network)
    figures = dict(psnr=field_figure(decoded, "NeuralPSNR"), ratio=field_figure(decoded, "NeuralCompressionRatio"),
                   seconds=field_figure(decoded, "NeuralTrainingSeconds"),
                   steps=int(field_figure(decoded, "NeuralSteps")),
                   model_bytes=int(field_figure(decoded, "NeuralModelBytes")),
                   max_difference=field_figure(decoded, "NeuralMaxError"),
                   device=field_figure(decoded, "NeuralDevice"),
                   compress_wall=time.time() - start)
    return network, decoded, figures


def render_pair(volume, network, folder):
    """Screenshots of the original (ParaView's Volume) and of the network (Neural Volume) with the same colour and
    opacity maps, shading and camera; returns their paths and render seconds."""
    view = CreateRenderView()
    view.ViewSize = [demo_picture.PANEL, demo_picture.PANEL]
    view.OrientationAxesVisibility = 0
    view.Background = demo_picture.BACKGROUND
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    lut = GetColorTransferFunction(demo_volume.ARRAY)
    lut.ApplyPreset("Inferno (matplotlib)", True)
    lut.AutomaticRescaleRangeMode = "Never"
    lut.RescaleTransferFunction(0.0, 1.0)
    opacity = GetOpacityTransferFunction(demo_volume.ARRAY)
    opacity.Points = [0.0, 0.0, 0.5, 0.0, 0.35, 0.0, 0.5, 0.0, 0.75, 0.08, 0.5, 0.0, 1.0, 0.9, 0.5, 0.0]
    shots, seconds = [], []
    for name, proxy, representation in (("original", volume, "Volume"), ("neural", network, "Neural Volume")):
        start = time.time()
        rep = Show(proxy, view, Representation=representation)
        rep.ColorArrayName = ["POINTS", demo_volume.ARRAY]
        rep.LookupTable = lut
        rep.ScalarOpacityFunction = opacity
        rep.Shade = 1
        Render(view)  # the first render of a view resets the camera: set it afterwards
        for key, value in CAMERA.items():
            setattr(view, key, value)
        Render(view)
        path = os.path.join(folder, name + ".png")
        SaveScreenshot(path, view, ImageResolution=[demo_picture.PANEL] * 2)
        Hide(proxy, view)
        shots.append(path)
        seconds.append(time.time() - start)
    return shots, seconds


def main():
    parser = argparse.ArgumentParser(description="NeuralVolume demo")
    parser.add_argument("plugin")
    parser.add_argument("output", nargs="?", default="neural_volume.png")
    parser.add_argument("--size", type=int, default=256, help="samples per axis of the Mandelbulb (default 256)")
    parser.add_argument("--budget", type=float, default=60.0, help="training time budget in seconds (default 60)")
    parser.add_argument("--steps", type=int, default=20000, help="at most this many training steps (default 20000)")
    parser.add_argument("--panels", help="keep the two renderings (original.png, neural.png) in this folder")
    args = parser.parse_args()
    LoadPlugin(args.plugin, remote=False, ns=globals())
    n = args.size
    start = time.time()

    volume = mandelbulb_source(n)
    say("demo: %d^3 Mandelbulb (float32, %.1f MB) computed in %.1f s" % (n, n ** 3 * 4 / 1e6, time.time() - start))
    say("demo: Neural Compress trains for up to %.0f s ..." % args.budget)
    network, decoded, figures = compress(volume, args.budget, args.steps)
    figures["size"] = n

    folder = args.panels or tempfile.mkdtemp(prefix="nv-demo-")
    os.makedirs(folder, exist_ok=True)
    (original_png, neural_png), (figures["render_original"], figures["render_neural"]) = \
        render_pair(volume, network, folder)
    demo_picture.compose(args.output, original_png, neural_png, servermanager.Fetch(volume), decoded,
                         servermanager.Fetch(network, idx=1), figures)
    if not args.panels:
        for path in (original_png, neural_png):
            os.remove(path)
        os.rmdir(folder)
    figures["total_wall"] = time.time() - start

    say("demo: %d steps in %.1f s on the %s; PSNR %.2f dB; ratio %.1f:1 (%.1f MB -> %.2f MB); max |difference| %.3g"
        % (figures["steps"], figures["seconds"], figures["device"], figures["psnr"], figures["ratio"],
           n ** 3 * 4 / 1e6, figures["model_bytes"] / 1e6, figures["max_difference"]))
    say("demo: picture %s (%.0f s in all)" % (os.path.abspath(args.output), figures["total_wall"]))
    say("demo figures: " + json.dumps(figures, sort_keys=True))


main()
