"""Inputs that cannot be trained (or only partly): each gives a clear message and a defined
result, never a crash."""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkImageData  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log

FAST = dict(TrainingSteps=40, BatchSize=4096, Levels=4, FeaturesPerLevel=2, NetworkWidth=16,
            HiddenLayers=1, Threads=2, PSNRInterval=0)


def image_source(values=None, dims=(16, 16, 16), name="f", extent=None):
    """A TrivialProducer holding a vtkImageData (with `values` as point array `name`)."""
    image = vtkImageData()
    if extent is not None:
        image.SetExtent(*extent)
    else:
        image.SetDimensions(*dims)
    image.SetSpacing(0.5, 0.5, 0.5)
    if values is not None:
        values = np.ascontiguousarray(values)
        array = numpy_to_vtk(values if values.ndim == 2 else values.ravel(), deep=1)
        array.SetName(name)
        image.GetPointData().SetScalars(array)
    producer = TrivialProducer()
    producer.GetClientSideObject().SetOutput(image)
    return producer


def run(producer, array=("POINTS", "f"), **extra):
    params = dict(FAST)
    params.update(extra)
    filt = NeuralCompress(Input=producer, **params)
    if array is not None:
        filt.SelectInputScalars = list(array)
    with nvtest.captured_messages() as messages:
        filt.UpdatePipeline()
        out = servermanager.Fetch(filt)
        table = servermanager.Fetch(filt, idx=1)
    text = messages[0]
    # An error is reported once, not again on every later pipeline update.
    check(text.count("ERROR:") <= 1, "an error is reported once (%d times)" % text.count("ERROR:"))
    return filt, out, table, text


def expect_empty(label, out, table, text, phrase):
    check(phrase in text, "%s: message contains %r; got %r" % (label, phrase, text))
    check("ERROR" in text, "%s: reported as an error" % label)
    # A defined result: no arrays at all (an image input keeps its geometry, others give nothing).
    check(out.GetPointData().GetNumberOfArrays() == 0 and out.GetCellData().GetNumberOfArrays() == 0,
          "%s: output 0 has no arrays" % label)
    check(out.GetFieldData().GetNumberOfArrays() == 0, "%s: output 0 has no field data" % label)
    check(out.GetFieldData().GetArray("NeuralNetwork") is None, "%s: no network" % label)
    check(table.GetNumberOfRows() == 0 and table.GetNumberOfColumns() == 5,
          "%s: empty training log with its columns" % label)


x, y, z = np.meshgrid(np.linspace(0, 1, 16), np.linspace(0, 1, 16), np.linspace(0, 1, 16), indexing="ij")
smooth = np.sin(3 * x) * np.cos(2 * y) + z  # (x, y, z) -> flatten in VTK order below
smooth = np.transpose(smooth, (2, 1, 0)).astype(np.float32)  # z slowest, x fastest

# --- NaN / Inf values ----------------------------------------------------------------------
bad = smooth.copy().ravel()
bad[::97] = np.nan
bad[5::211] = np.inf
bad[7::307] = -np.inf
n_invalid = int(np.count_nonzero(~np.isfinite(bad)))
filt, out, table, text = run(image_source(bad))
check("NaN or Inf" in text and "excluded from training" in text and "Warning" in text,
      "NaN/Inf: warning printed (%r)" % text)
check(nvtest.field_value(out, "NeuralInvalidSamples") == n_invalid,
      "NaN/Inf: NeuralInvalidSamples == %d (got %r)" % (n_invalid, nvtest.field_value(out, "NeuralInvalidSamples")))
decoded = vtk_to_numpy(out.GetPointData().GetArray("f"))
check(decoded.size == 16 ** 3 and np.all(np.isfinite(decoded)), "NaN/Inf: decoded values are all finite")
psnr = nvtest.field_value(out, "NeuralPSNR")
check(psnr is not None and math.isfinite(psnr) and psnr > 10.0, "NaN/Inf: PSNR over valid voxels (%r)" % psnr)
check(nvtest.field_value(out, "NeuralSteps") == 40, "NaN/Inf: training ran")
Delete(filt)

# --- all values invalid ----------------------------------------------------------------------
filt, out, table, text = run(image_source(np.full(16 ** 3, np.nan, dtype=np.float32)))
expect_empty("all NaN", out, table, text, "are NaN or Inf; nothing to train on")
Delete(filt)

# --- constant field ------------------------------------------------------------------------
filt, out, table, text = run(image_source(np.full(16 ** 3, 3.25, dtype=np.float64)))
check("is constant" in text and "Warning" in text, "constant: warning printed (%r)" % text)
decoded = vtk_to_numpy(out.GetPointData().GetArray("f"))
check(decoded.size == 16 ** 3 and np.all(decoded == 3.25), "constant: decoded exactly (%r..%r)"
      % (decoded.min(), decoded.max()))
check(nvtest.field_value(out, "NeuralSteps") == 0, "constant: training skipped")
check(nvtest.field_value(out, "NeuralPSNR") == math.inf, "constant: PSNR is +inf")
check(nvtest.field_value(out, "NeuralMaxError") == 0.0, "constant: max error 0")
check(table.GetNumberOfRows() == 0, "constant: empty log")
Delete(filt)

# --- empty extent --------------------------------------------------------------------------
filt, out, table, text = run(image_source(None, extent=(0, -1, 0, -1, 0, -1)), array=None)
expect_empty("empty extent", out, table, text, "empty extent")
check(out.GetNumberOfPoints() == 0, "empty extent: no points")
Delete(filt)

# --- degenerate (flat) extent: a 2D image still works ------------------------------------------
flat = np.sin(np.linspace(0, 6, 32 * 32)).astype(np.float32)
filt, out, table, text = run(image_source(flat, dims=(32, 32, 1)))
check("ERROR" not in text, "2D image: no error (%r)" % text)
check(out.GetDimensions() == (32, 32, 1), "2D image: output dims %r" % (out.GetDimensions(),))
Delete(filt)

# --- negative spacing: refused before training, with the way out -----------------------------------
neg = image_source(np.sin(np.linspace(0, 6, 16 ** 3)).astype(np.float32))
neg.GetClientSideObject().GetOutputDataObject(0).SetSpacing(-0.5, 0.5, 0.5)
filt, out, table, text = run(neg)
expect_empty("negative spacing", out, table, text, "cannot be stored with a network")
check("negative spacing" in text, "negative spacing: the message says how to flip the image (%r)" % text)
Delete(filt)

# --- a single voxel ------------------------------------------------------------------------
filt, out, table, text = run(image_source(np.array([7.0], dtype=np.float32), dims=(1, 1, 1)))
check(out.GetNumberOfPoints() == 1 and vtk_to_numpy(out.GetPointData().GetArray("f"))[0] == 7.0,
      "single voxel: represented exactly")
Delete(filt)

# --- no array ------------------------------------------------------------------------------
filt, out, table, text = run(image_source(None), array=None)
expect_empty("no array", out, table, text, "no input array")
Delete(filt)

# --- vector component out of range ----------------------------------------------------------
vec = np.stack([smooth.ravel(), 2 * smooth.ravel()], axis=1)
filt, out, table, text = run(image_source(vec), VectorMode="Component", VectorComponent=5)
expect_empty("bad component", out, table, text, "VectorComponent 5 is out of range")
Delete(filt)

# --- configuration rejected by the engine ----------------------------------------------------
filt, out, table, text = run(image_source(smooth.ravel()), Levels=40)
expect_empty("bad config", out, table, text, "Neural Compress:")
log("engine configuration error: %s" % text.strip().splitlines()[-1] if text.strip() else "")
Delete(filt)

# --- non-image inputs that cannot be resampled (any dataset trains: TestNeuralCompressAnyDataset.py) -------------
wavelet = Wavelet(WholeExtent=[-4, 4, -4, 4, -4, 4])
tets = Tetrahedralize(Input=wavelet)
filt, out, table, text = run(tets, array=("POINTS", "RTData"), SamplingDimensions=[2000, 2000, 2000])
expect_empty("huge SamplingDimensions", out, table, text, "exceed 2^30 samples")
check("vtkUnstructuredGrid" in text, "huge SamplingDimensions: the message names the input type")
Delete(filt)
filt, out, table, text = run(tets, array=("CELLS", "NoSuchArray"))
expect_empty("missing array", out, table, text, "no block of the input has a cell array 'NoSuchArray'")
Delete(filt)

# --- device selection ----------------------------------------------------------------------------
# CPU: no GPU memory; the GPU training strategy is ignored there.
filt, out, table, text = run(image_source(smooth.ravel()), Device="CPU", TrainingStrategy="Host-sampled")
check(nvtest.field_value(out, "NeuralDevice") == "CPU", "Device=CPU trains on the CPU")
check(nvtest.field_value(out, "NeuralGpuMemoryBytes") == 0, "CPU run reports 0 bytes of GPU memory")
Delete(filt)
# CUDA: an error naming the reason where no GPU is usable; a GPU run reporting its memory otherwise.
filt, out, table, text = run(image_source(smooth.ravel()), Device="CUDA")
if "not usable" in text:
    expect_empty("CUDA without a GPU", out, table, text, "CUDA device requested but not usable")
    log("Device=CUDA without a GPU: %s" % text.strip().splitlines()[-1])
else:
    check(nvtest.field_value(out, "NeuralDevice") == "CUDA", "Device=CUDA trains on the GPU (%r)" % text)
    check(nvtest.field_value(out, "NeuralGpuMemoryBytes") > 0, "GPU run reports its GPU memory")
Delete(filt)

# --- an absurd learning rate: the run rolls back and lowers it, says so, and reports honest figures -----------
filt, out, table, text = run(image_source(smooth.ravel()), LearningRate=1e6, TrainingSteps=120, PSNRInterval=20)
psnr, max_error = nvtest.field_value(out, "NeuralPSNR"), nvtest.field_value(out, "NeuralMaxError")
log("LearningRate 1e6: PSNR %s, max error %s; %s" % (psnr, max_error, " | ".join(
    l for l in text.splitlines() if "diverged" in l or "kept" in l)[:400]))
check("training diverged at step" in text and "lowered the learning rate" in text,
      "LearningRate 1e6: the rollback is reported as a warning")
check(psnr is not None and math.isfinite(psnr) and max_error is not None and math.isfinite(max_error) and max_error > 0,
      "LearningRate 1e6: finite, non-zero figures, never +inf dB (%s, %s)" % (psnr, max_error))
check(nvtest.field_value(out, "NeuralSteps") == 120, "LearningRate 1e6: the run finishes its steps")
Delete(filt)

# --- the session is still usable after all that ------------------------------------------------
filt, out, table, text = run(image_source(smooth.ravel()))
check(out.GetNumberOfPoints() == 16 ** 3 and nvtest.field_value(out, "NeuralSteps") == 40,
      "a valid run after the bad ones works")

nvtest.finish()
