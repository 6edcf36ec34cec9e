"""Neural Compress on a 64^3 Wavelet: outputs, field data, metrics, training log, resampling,
cell and vector arrays, time budget, progress and abort."""
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log

# Small, fast configuration (2 cores): measured PSNR 27.1 dB after 300 steps (L2 loss).
FAST = dict(BatchSize=16384, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2,
            Loss="L2", Threads=2, Seed=1)
PSNR_THRESHOLD = 25.0
TARGET = 10.0

wavelet = Wavelet(WholeExtent=[-31, 32, -31, 32, -31, 32])
source = servermanager.Fetch(wavelet)
original = vtk_to_numpy(source.GetPointData().GetArray("RTData")).astype(np.float64)
vmin, vmax = original.min(), original.max()

# --- defaults of the proxy (the README documents them) -------------------------------------
probe = NeuralCompress(Input=wavelet)
defaults = dict(TrainingSteps=2000, TimeBudget=60.0, BatchSize=65536, LearningRate=0.01, Seed=1,
                TargetCompressionRatio=0.0, Levels=16, FeaturesPerLevel=4, Log2TableSize="Automatic",
                BaseResolution=16, FinestResolution=0, NetworkWidth=64, HiddenLayers=4,
                Loss="L1", LearningRateSchedule="Annealed (cosine to 1/100 over the run)",
                StoragePrecision="Automatic", Device="Auto", Threads=0, PSNRInterval=100,
                VectorMode="Magnitude", VectorComponent=0, TargetPSNR=0.0, Deterministic=0, WarmStart=1,
                NetworkCacheMiB=256, ContinueSteps=1000)
for name, value in defaults.items():
    actual = probe.GetPropertyValue(name)
    ok = (actual == value) or (actual == str(value))
    check(ok, "default %s = %r, expected %r" % (name, actual, value))
check(list(probe.OutputResolution) == [0, 0, 0], "default OutputResolution")
Delete(probe)

# --- (a) main run ------------------------------------------------------------------------
nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=300, TimeBudget=0,
                    PSNRInterval=50, TargetCompressionRatio=TARGET, **FAST)
with nvtest.captured_messages() as messages:
    nc.UpdatePipeline()
text = messages[0]
check("Neural Compress: 'RTData'" in text and "300 steps" in text and "PSNR" in text,
      "one-line summary printed: %r" % text)
check("ERROR" not in text and "Warning" not in text, "no error/warning on a clean run: %r" % text)

out = servermanager.Fetch(nc)
check(out.IsA("vtkImageData"), "output 0 is vtkImageData")
check(out.GetDimensions() == source.GetDimensions(), "output dimensions equal the input's")
check(np.allclose(out.GetBounds(), source.GetBounds()), "output bounds equal the input's")
decoded_array = out.GetPointData().GetArray("RTData")
check(decoded_array is not None and decoded_array.GetDataType() == 10,  # VTK_FLOAT
      "decoded point array RTData (float)")
check(out.GetPointData().GetScalars() is decoded_array, "decoded array is the active scalars")
decoded = vtk_to_numpy(decoded_array).astype(np.float64)
check(np.all(np.isfinite(decoded)), "decoded values are finite")

fd = out.GetFieldData()
expected_types = {"NeuralNetwork": "vtkUnsignedCharArray", "NeuralTrainingSeconds": "vtkDoubleArray",
                  "NeuralSteps": "vtkTypeInt64Array", "NeuralPSNR": "vtkDoubleArray",
                  "NeuralMaxError": "vtkDoubleArray", "NeuralCompressionRatio": "vtkDoubleArray",
                  "NeuralModelBytes": "vtkTypeInt64Array", "NeuralInvalidSamples": "vtkTypeInt64Array",
                  "NeuralGpuMemoryBytes": "vtkTypeInt64Array", "NeuralDevice": "vtkStringArray"}
for name, cls in expected_types.items():
    array = fd.GetAbstractArray(name)
    check(array is not None and array.IsA(cls), "field data %s (%s)" % (name, cls))

network = vtk_to_numpy(fd.GetArray("NeuralNetwork"))
check(bytes(network[:8]) == b"NVOLNET\0", "NeuralNetwork starts with the format magic")
steps = nvtest.field_value(out, "NeuralSteps")
psnr = nvtest.field_value(out, "NeuralPSNR")
max_error = nvtest.field_value(out, "NeuralMaxError")
ratio = nvtest.field_value(out, "NeuralCompressionRatio")
model_bytes = nvtest.field_value(out, "NeuralModelBytes")
seconds = nvtest.field_value(out, "NeuralTrainingSeconds")
log("wavelet: %d steps in %.2f s, PSNR %.2f dB, max error %.2f, ratio %.2f, model %d bytes"
    % (steps, seconds, psnr, max_error, ratio, model_bytes))
check(steps == 300, "NeuralSteps == 300 (got %r)" % steps)
check(psnr >= PSNR_THRESHOLD, "PSNR %.2f dB >= %.1f dB" % (psnr, PSNR_THRESHOLD))
check(nvtest.field_value(out, "NeuralInvalidSamples") == 0, "no invalid samples")
check(nvtest.field_value(out, "NeuralDevice") == "CPU", "trained on the CPU (no GPU here)")
check(0.0 < seconds < 120.0, "training time is plausible (%r s)" % seconds)
check(len(network) > model_bytes, "serialized network holds the parameters")

# The reported metrics agree with an independent computation on the decoded output.
mse = np.mean(((decoded - original) / (vmax - vmin)) ** 2)
own_psnr = 10.0 * math.log10(1.0 / mse)
nvtest.check_close(psnr, own_psnr, 0.05, "NeuralPSNR vs PSNR of the decoded output")
nvtest.check_close(max_error, np.max(np.abs(decoded - original)), 1e-3 * (vmax - vmin),
                   "NeuralMaxError vs max |decoded - input|")
raw_bytes = original.size * 4
nvtest.check_close(ratio, raw_bytes / model_bytes, 1e-9 * ratio, "ratio == raw bytes / model bytes")
# The table size is the largest that keeps the target, so the ratio is within a factor ~2 of it.
check(TARGET <= ratio < 2.2 * TARGET, "ratio %.2f close to the target %.1f" % (ratio, TARGET))

# --- training log -----------------------------------------------------------------------
log_table = servermanager.Fetch(nc, idx=1)
columns = [log_table.GetColumnName(i) for i in range(log_table.GetNumberOfColumns())]
check(columns == ["Step", "Loss", "LearningRate", "ElapsedSeconds", "PSNR"], "log columns %r" % columns)
check(log_table.GetNumberOfRows() == 300, "one log row per step")
col = {name: vtk_to_numpy(log_table.GetColumnByName(name)) for name in columns}
check(np.array_equal(col["Step"], np.arange(1, 301)), "Step column 1..300")
check(np.all(np.diff(col["ElapsedSeconds"]) >= 0), "ElapsedSeconds non-decreasing")
# The default schedule (annealed) holds the full rate for the first 500 steps: all of this run.
check(np.allclose(col["LearningRate"], 0.01), "learning rate constant 0.01 over a run shorter than the hold")
check(np.all(np.isfinite(col["Loss"])) and col["Loss"][-20:].mean() < 0.5 * col["Loss"][:20].mean(),
      "loss decreases (first 20 mean %.4g, last 20 mean %.4g)"
      % (col["Loss"][:20].mean(), col["Loss"][-20:].mean()))
has_psnr = np.isfinite(col["PSNR"])
check(np.array_equal(np.nonzero(has_psnr)[0] + 1, [50, 100, 150, 200, 250, 300]),
      "PSNR logged at steps 50,100,..,300 only (got %r)" % list(np.nonzero(has_psnr)[0] + 1))
check(col["PSNR"][-1] == psnr, "last logged PSNR is the final one")
check(abs(col["PSNR"][249] - psnr) < 3.0, "estimated PSNR at step 250 (%.2f) is close to the final"
      % col["PSNR"][249])

# --- resampled output (OutputResolution) ------------------------------------------------
nc.OutputResolution = [32, 40, 16]
nc.TrainingSteps = 60
nc.UpdatePipeline()
res = servermanager.Fetch(nc)
check(res.GetDimensions() == (32, 40, 16), "OutputResolution gives %r" % (res.GetDimensions(),))
check(np.allclose(res.GetBounds(), source.GetBounds()), "resampled output keeps the input bounds")
check(res.GetPointData().GetArray("RTData").GetNumberOfTuples() == 32 * 40 * 16, "resampled values")
nc.OutputResolution = [0, 0, 0]

# --- cell array -------------------------------------------------------------------------
cells = PointDatatoCellData(Input=wavelet)
nc_cells = NeuralCompress(Input=cells, SelectInputScalars=["CELLS", "RTData"], TrainingSteps=60, **FAST)
nc_cells.UpdatePipeline()
cout = servermanager.Fetch(nc_cells)
check(cout.GetDimensions() == source.GetDimensions(), "cell input: same geometry")
carray = cout.GetCellData().GetArray("RTData")
check(carray is not None and carray.GetNumberOfTuples() == 63 ** 3, "cell input: decoded cell data")
check(cout.GetPointData().GetNumberOfArrays() == 0, "cell input: no point data")
check(nvtest.field_value(cout, "NeuralPSNR") > 15.0, "cell input trains")
nc_cells.OutputResolution = [20, 21, 22]  # cells of the resampled output
nc_cells.UpdatePipeline()
cres = servermanager.Fetch(nc_cells)
check(cres.GetDimensions() == (21, 22, 23), "cell input resampled to 20x21x22 cells (%r points)"
      % (cres.GetDimensions(),))
check(np.allclose(cres.GetBounds(), source.GetBounds()), "resampled cell output keeps the input bounds")
cvals = vtk_to_numpy(cres.GetCellData().GetArray("RTData"))
check(cvals.size == 20 * 21 * 22 and np.all(np.isfinite(cvals)), "resampled cell values")
check(abs(cvals.mean() - original.mean()) < 0.1 * (vmax - vmin), "resampled cell values match the field's mean")

# --- vector array: magnitude and component ------------------------------------------------
calc = Calculator(Input=wavelet, ResultArrayName="Vec", Function="RTData*iHat + 2*RTData*jHat")
for mode, comp, expected in (("Magnitude", 0, math.sqrt(5.0)), ("Component", 1, 2.0)):
    nv_vec = NeuralCompress(Input=calc, SelectInputScalars=["POINTS", "Vec"], VectorMode=mode,
                            VectorComponent=comp, TrainingSteps=60, **FAST)
    nv_vec.UpdatePipeline()
    vout = servermanager.Fetch(nv_vec)
    varray = vout.GetPointData().GetArray("Vec")
    check(varray is not None and varray.GetNumberOfComponents() == 1, "%s: scalar output" % mode)
    lo, hi = varray.GetRange()
    # The decoded field spans (about) the scaled RTData range.
    check(abs(0.5 * (lo + hi) - expected * 0.5 * (vmin + vmax)) < 0.2 * expected * (vmax - vmin),
          "%s: decoded range %r matches %g x RTData" % (mode, (lo, hi), expected))
    Delete(nv_vec)

# --- time budget ------------------------------------------------------------------------
nc_time = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=1000000,
                         TimeBudget=1.5, PSNRInterval=0, **FAST)
apply_start = time.time()
nc_time.UpdatePipeline()
apply_seconds = time.time() - apply_start
tout = servermanager.Fetch(nc_time)
t_steps = nvtest.field_value(tout, "NeuralSteps")
t_seconds = nvtest.field_value(tout, "NeuralTrainingSeconds")
log("time budget 1.5 s: %d steps in %.2f s of training, the Apply took %.2f s" % (t_steps, t_seconds, apply_seconds))
check(0 < t_steps < 1000000, "time budget stops training (%d steps)" % t_steps)
# The budget bounds the whole Apply (preparing, training, the final measurement); within 10% is measured alone on the
# machine by nv.pv.NeuralCompressTimeBudget, here beside other tests the bound is looser below.
check(1.1 <= apply_seconds <= 1.65, "the Apply took %.2f s for the 1.5 s budget" % apply_seconds)
check(t_seconds <= 1.5, "training time %.2f s within the 1.5 s budget" % t_seconds)
Delete(nc_time)

# --- (f) progress and abort ---------------------------------------------------------------
nc_abort = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=400,
                          PSNRInterval=0, **FAST)
algorithm = nc_abort.GetClientSideObject()
progress = []


def on_progress(obj, event):
    progress.append(obj.GetProgress())
    if obj.GetProgress() >= 0.25:
        obj.SetAbortExecute(1)


algorithm.AddObserver("ProgressEvent", on_progress)
nc_abort.UpdatePipeline()
aout = servermanager.Fetch(nc_abort)
a_steps = nvtest.field_value(aout, "NeuralSteps")
log("abort at 25%%: %r steps, %d progress events" % (a_steps, len(progress)))
check(len(set(progress)) > 10, "progress moves during training (%d distinct values)" % len(set(progress)))
check(a_steps is not None and 0 < a_steps < 400, "abort stops training early (%r steps)" % a_steps)
check(aout.GetDimensions() == source.GetDimensions() and aout.GetPointData().GetArray("RTData"),
      "aborted run still produces a valid output")
check(aout.GetFieldData().GetArray("NeuralNetwork") is not None, "aborted run still stores the network")

nvtest.finish()
