"""Neural Compress never reports a wrong number (the rows "Wrong or misleading results" of the issue): each case
checks the decoded output with numpy against the input (relative to the input's range, in extended precision), the
filter's own figures against numpy's, and its messages.

1. a vtkBitArray decodes to bits (thresholded at 0.5); the filter's PSNR and max error are the bits'.
2. a float32 field reaching +-3.4e38: decoded values saturate at +-FLT_MAX, never inf; finite, right figures.
3. a float64 field of +-1.5e308 whose max error exceeds the largest double: reported as such (NeuralMaxErrorOfRange,
   the summary's extended-precision figure), not as a diverged training.
4. .nvol files whose extent is not their network's (2^20 per axis: 2^60 points) are refused, each opened in a pvbatch
   of its own under `ulimit -v` 8 GB and a 30 s limit.
5. Training Steps 0 says no training was asked for (a warning); a negative count is refused (set to 0, a warning).
6. zero spacing gets its own advice, not the one for negative spacing.
7. an abort asked at the first progress event stops the training (state Aborted, a warning).
8. a new OutputResolution decodes the same network again: no training step, the new dimensions, the same values.

    pvbatch TestNeuralCompressWrongResults.py [--open file.nvol]   (--open: case 4's subprocess)"""
import math
import os
import re
import struct
import subprocess
import sys
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonCore import vtkBitArray, vtkCommand  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkImageData  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
LD = np.longdouble  # 80-bit on x86-64: differences of doubles up to 2 * DBL_MAX stay finite
FLT_MAX, DBL_MAX = float(np.finfo(np.float32).max), float(np.finfo(np.float64).max)

if "--open" in sys.argv:
    # Case 4's subprocess: open one .nvol, print what the reader said and the points of its output.
    with nvtest.captured_messages() as messages:
        reader = OpenDataFile(sys.argv[sys.argv.index("--open") + 1])
        reader.UpdatePipeline()
        points = servermanager.Fetch(reader).GetNumberOfPoints()
    sys.stdout.write("%s\nPOINTS %d\n" % (messages[0], points))
    nvtest.finish()
    nvtest._exit(0)

NET = dict(Device="CPU", Threads=2, TrainInBackground=0, BatchSize=8192, Deterministic=1, PSNRInterval=0, Levels=8,
           FeaturesPerLevel=2, Log2TableSize=14, NetworkWidth=32, HiddenLayers=2)
N = 33  # the Wavelet's samples per axis (extent -16..16): 17 output samples per axis are every other one
wavelet = Wavelet(WholeExtent=[-16, 16, -16, 16, -16, 16])
rt = vtk_to_numpy(servermanager.Fetch(wavelet).GetPointData().GetArray("RTData")).astype(np.float64)
signed = (rt - rt.min()) / (rt.max() - rt.min()) * 2.0 - 1.0  # exactly -1 .. 1


def image(values, bits=False, spacing=(1.0, 1.0, 1.0)):
    """A TrivialProducer of an N^3 image with the point array 'f' (a vtkBitArray when bits)."""
    im = vtkImageData()
    im.SetDimensions(N, N, N)
    im.SetSpacing(*spacing)
    if bits:
        array = vtkBitArray()
        array.SetNumberOfTuples(values.size)
        for i, v in enumerate(values):
            array.SetValue(i, int(v))
    else:
        array = numpy_to_vtk(values, deep=True)
    array.SetName("f")
    im.GetPointData().AddArray(array)
    producer = TrivialProducer()
    producer.GetClientSideObject().SetOutput(im)
    return producer


def run(producer, **settings):
    """The filter on 'f' with NET and `settings`: (filter, output, messages)."""
    with nvtest.captured_messages() as messages:
        nc = NeuralCompress(Input=producer, SelectInputScalars=["POINTS", "f"], **dict(NET, **settings))
        nc.UpdatePipeline()
        out = servermanager.Fetch(nc)
    return nc, out, messages[0]


def decoded_values(out):
    a = out.GetPointData().GetArray("f")
    if a is None:
        return None, None
    if a.IsA("vtkBitArray"):
        return np.array([a.GetValue(i) for i in range(a.GetNumberOfTuples())], np.uint8), a.GetClassName()
    return vtk_to_numpy(a).copy(), a.GetClassName()


def measure(decoded, source):
    """(PSNR dB, max |error| in source units, max |error| / range), in extended precision."""
    d, v = decoded.astype(LD), source.astype(LD)
    diff = d - v
    rel = diff / (v.max() - v.min())
    mse = float(np.mean(rel * rel))
    return (math.inf if mse == 0 else 10 * math.log10(1 / mse)), np.abs(diff).max(), float(np.abs(rel).max())


def sci(value):
    """A long double in scientific notation (beyond the largest double too)."""
    return np.format_float_scientific(value, precision=4)


def agrees(label, out, decoded, source, psnr_tol=0.01):
    """The filter's PSNR and max error are numpy's on the output; returns numpy's figures."""
    p, maxerr, rel = measure(decoded, source)
    reported = nvtest.field_value(out, "NeuralPSNR")
    reported_max = nvtest.field_value(out, "NeuralMaxError")
    reported_rel = nvtest.field_value(out, "NeuralMaxErrorOfRange")
    log("%s: numpy PSNR %.3f dB, max error %s (%.4f of the range); filter %r dB, %r (%r)"
        % (label, p, sci(maxerr), rel, reported, reported_max, reported_rel))
    check(reported is not None and math.isfinite(reported) and abs(reported - p) <= psnr_tol,
          "%s: the filter's PSNR %r is numpy's %.4f (within %g dB)" % (label, reported, p, psnr_tol))
    check(reported_rel is not None and math.isfinite(reported_rel) and abs(reported_rel - rel) <= 1e-6 * max(rel, 1e-300),
          "%s: NeuralMaxErrorOfRange %r is numpy's %.9g" % (label, reported_rel, rel))
    if maxerr <= DBL_MAX:
        check(reported_max is not None and math.isfinite(reported_max)
              and abs(LD(reported_max) - maxerr) <= LD(1e-6) * maxerr,
              "%s: NeuralMaxError %r is numpy's %s" % (label, reported_max, sci(maxerr)))
    return p, maxerr, rel


rows = []  # (case, outcome, figures) for the README

# --- 1. A bit array ----------------------------------------------------------------------------------------------------
bits = (signed > 0).astype(np.uint8)
nc, out, text = run(image(bits, bits=True), TrainingSteps=100, OutputMode="Decoded, input type")
decoded, kind = decoded_values(out)
check(kind == "vtkBitArray" and decoded is not None and decoded.size == bits.size, "bits: a vtkBitArray output (%s)"
      % kind)
match = float(np.mean(decoded == bits))
check(match >= 0.995, "bits: at least 99.5%% of the bits match (%.4f)" % match)
check("ERROR" not in text, "bits: no error (%s)" % text.strip()[-300:])
p, _, _ = agrees("bits", out, decoded, bits)
nc.OutputMode = "Decoded, float32"  # the same network (no retraining): the bits are its values thresholded at 0.5
nc.UpdatePipeline()
floats, _ = decoded_values(servermanager.Fetch(nc))
check(np.array_equal(decoded, (floats >= 0.5).astype(np.uint8)), "bits: the decoded floats thresholded at 0.5")
rows.append(("vtkBitArray, 'Decoded, input type'", "bits (threshold 0.5)",
             "%.2f%% of the bits match; PSNR %.2f dB (filter %.2f)" % (100 * match, p,
                                                                       nvtest.field_value(out, "NeuralPSNR"))))
Delete(nc)

# --- 2. float32 up to 3.4e38 -----------------------------------------------------------------------------------------------
for steps, mode in ((30, "Decoded, input type"), (30, "Decoded, float32")):
    source = (signed * 3.4e38).astype(np.float32)
    nc, out, text = run(image(source), TrainingSteps=steps, OutputMode=mode)
    decoded, kind = decoded_values(out)
    label = "float32 x3.4e38, %s" % mode
    check(kind == "vtkFloatArray", "%s: a float output (%s)" % (label, kind))
    check(bool(np.all(np.isfinite(decoded))), "%s: no inf or NaN (%d)" % (label, np.count_nonzero(~np.isfinite(decoded))))
    saturated = int(np.count_nonzero(np.abs(decoded) == np.float32(FLT_MAX)))
    check(saturated > 0, "%s: the network overshoots FLT_MAX somewhere and saturates there (%d samples)"
          % (label, saturated))
    check("ERROR" not in text and "diverged" not in text, "%s: no error (%s)" % (label, text.strip()[-300:]))
    p, maxerr, rel = agrees(label, out, decoded, source)
    rows.append((label, "finite, %d samples at +-FLT_MAX" % saturated,
                 "PSNR %.2f dB (filter %.2f), max error %s" % (p, nvtest.field_value(out, "NeuralPSNR"), sci(maxerr))))
    Delete(nc)

# --- 3. float64 +-1.5e308, max error above DBL_MAX ---------------------------------------------------------------------
source = signed * 1.5e308
for steps in (5, 100):
    nc, out, text = run(image(source), TrainingSteps=steps, OutputMode="Decoded, input type")
    decoded, _ = decoded_values(out)
    label = "float64 +-1.5e308, %d steps" % steps
    check(bool(np.all(np.isfinite(decoded))), "%s: decoded values finite" % label)
    check("ERROR" not in text and "diverged" not in text and "NaN or Inf" not in text,
          "%s: not reported as a divergence (%s)" % (label, text.strip()[-300:]))
    p, maxerr, rel = agrees(label, out, decoded, source)
    summary = re.search(r"max error ([0-9.e+-]+)", text)
    if maxerr > DBL_MAX:
        check(math.isinf(nvtest.field_value(out, "NeuralMaxError")), "%s: NeuralMaxError overflows to inf" % label)
        check("too large for a double" in text and "Warning" in text, "%s: a warning says the max error is beyond a "
              "double (%s)" % (label, text.strip()[-300:]))
        figure = LD(summary.group(1)) if summary else LD(0)
        check(abs(figure - maxerr) <= LD(1e-3) * maxerr, "%s: the summary's max error %s is numpy's %s"
              % (label, summary.group(1) if summary else None, sci(maxerr)))
    rows.append((label, "finite; max error %s" % ("above DBL_MAX: reported of the range" if maxerr > DBL_MAX
                                                  else "finite"),
                 "PSNR %.2f dB (filter %.2f), max error %s = %.4f of the range (filter %s)"
                 % (p, nvtest.field_value(out, "NeuralPSNR"), sci(maxerr), rel,
                    summary.group(1) if summary else "-")))
    Delete(nc)

# --- 4. .nvol extents that are not their network's -------------------------------------------------------------------
out_dir = os.path.join(nvtest.output_dir(), "wrong_results")
os.makedirs(out_dir, exist_ok=True)
small = Wavelet(WholeExtent=[0, 15, 0, 15, 0, 15])
saver = NeuralCompress(Input=small, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=20,
                       **dict(NET, OutputMode="Network only"))
good_path = os.path.join(out_dir, "good.nvol")
SaveData(good_path, proxy=saver)
good = open(good_path, "rb").read()
Delete(saver)


def crafted(name, extent=None, source_dims=None, decoded_dims=None, on_grid=None):
    """good.nvol with its first entry's fields replaced (offsets: time 16, extent 24, source dims 176, decoded dims
    188, on-grid flag 200), its CRC recomputed."""
    body = bytearray(good[:-4])
    if extent is not None:
        body[24:48] = struct.pack("<6i", *extent)
    if source_dims is not None:
        body[176:188] = struct.pack("<3i", *source_dims)
    if decoded_dims is not None:
        body[188:200] = struct.pack("<3i", *decoded_dims)
    if on_grid is not None:
        body[200:204] = struct.pack("<i", on_grid)
    path = os.path.join(out_dir, name + ".nvol")
    with open(path, "wb") as f:
        f.write(bytes(body) + struct.pack("<I", zlib.crc32(bytes(body)) & 0xffffffff))
    return path


BIG = (1 << 20) - 1
pvbatch = os.environ.get("NV_PVBATCH", "pvbatch")
for name, path, phrase in (
        ("good", good_path, None),
        ("extent 2^20 per axis", crafted("extent", extent=(0, BIG) * 3),
         "the extent's 1048576 points on axis x hold 1048576 points, the entry decodes 16"),
        ("extent and decoded dims 2^20", crafted("decoded", extent=(0, BIG) * 3, decoded_dims=(BIG + 1,) * 3,
                                                 on_grid=0),
         "(1152921504606846976 points) exceeds the 2^34 points"),
        ("source dims not the network's", crafted("source", extent=(0, 31) * 3, source_dims=(32,) * 3,
                                                  decoded_dims=(32,) * 3),
         "the entry's source grid 32 x 32 x 32 is not its network's (16 x 16 x 16)")):
    started = time.time()
    try:
        proc = subprocess.run(["sh", "-c", 'ulimit -v 8000000; exec "$0" "$@"', pvbatch, os.path.abspath(__file__),
                               "--open", path], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=30)
        code, text = proc.returncode, proc.stdout.decode(errors="replace")
    except subprocess.TimeoutExpired:
        code, text = None, "(timed out)"
    seconds = time.time() - started
    points = re.search(r"POINTS (\d+)", text)
    points = int(points.group(1)) if points else -1
    log(".nvol %s: exit %r in %.1f s, %d points; %s" % (name, code, seconds, points, text.strip()[-300:]))
    check(code == 0, ".nvol %s: a normal exit within 30 s under ulimit -v 8 GB (exit %r)" % (name, code))
    if phrase is None:
        check("ERROR" not in text and points == 16 ** 3, ".nvol %s: read (%d points)" % (name, points))
        continue
    check(phrase in text and text.count("ERROR") == 1 and points == 0,
          ".nvol %s: one error %r and an empty output (%d points)" % (name, phrase, points))
    rows.append((".nvol, " + name, "refused", "%r, %.1f s" % (phrase, seconds)))

# --- 5. Training Steps 0 and negative -----------------------------------------------------------------------------------
for steps in (0, -5):
    nc, out, text = run(image(signed), TrainingSteps=steps, OutputMode="Decoded, float32")
    decoded, _ = decoded_values(out)
    nc.SMProxy.UpdatePropertyInformation()
    status = nc.GetPropertyValue("TrainingStatus")
    label = "TrainingSteps %d" % steps
    check(nvtest.field_value(out, "NeuralSteps") == 0, "%s: no step" % label)
    check("constant" not in text and "constant" not in status, "%s: no '(constant field)' (%r)" % (label, status))
    check("Training Steps is 0: no training was asked for" in text and "Warning" in text,
          "%s: a warning says no training was asked for (%s)" % (label, text.strip()[-400:]))
    if steps < 0:
        check("Training Steps -5 is negative: set to 0" in text, "%s: refused with a warning" % label)
    agrees(label, out, decoded, signed, psnr_tol=0.05)
    rows.append((label, "warning: no training asked%s" % ("; negative set to 0" if steps < 0 else ""),
                 "0 steps, PSNR %.2f dB of the initialisation" % nvtest.field_value(out, "NeuralPSNR")))
    Delete(nc)

# --- 6. Zero spacing ----------------------------------------------------------------------------------------------------
nc, out, text = run(image(signed, spacing=(0.0, 0.0, 0.0)), TrainingSteps=10)
check("zero spacing on axis x, y, z" in text and "negative spacing" not in text and text.count("ERROR") == 1,
      "zero spacing: its own advice (%s)" % text.strip()[-400:])
check(out.GetFieldData().GetArray("NeuralNetwork") is None, "zero spacing: no network")
rows.append(("spacing 0 0 0", "error: zero spacing on axis x, y, z", "-"))
Delete(nc)

# --- 7. Abort at the first progress event ---------------------------------------------------------------------------------
nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], TrainingSteps=2000,
                    **dict(NET, OutputMode="Decoded, float32"))
algorithm = nc.GetClientSideObject()
events = []


def abort_at_first(caller, event):
    events.append(caller.GetProgress())
    if len(events) == 1:
        caller.SetAbortExecute(1)


observer = algorithm.AddObserver(vtkCommand.ProgressEvent, abort_at_first)
started = time.time()
with nvtest.captured_messages() as messages:
    nc.UpdatePipeline()
seconds = time.time() - started
algorithm.RemoveObserver(observer)
out = servermanager.Fetch(nc)
steps = nvtest.field_value(out, "NeuralSteps")
state = nvtest.field_value(out, "NeuralTrainingState")
log("abort at the first progress event (%r): %r steps, state %r, %.1f s; %s"
    % (events[:1], steps, state, seconds, messages[0].strip()[-300:]))
check(steps is not None and steps <= 1 and state == "Aborted", "abort: training stopped at once (%r steps, state %r)"
      % (steps, state))
check("training aborted (AbortExecute) at step" in messages[0] and "(aborted)" in messages[0],
      "abort: a warning and the summary say so (%s)" % messages[0].strip()[-300:])
rows.append(("AbortExecute at the first progress event", "state Aborted, warning", "%d of 2000 steps, %.1f s"
             % (steps, seconds)))
Delete(nc)

# --- 8. OutputResolution re-decodes ---------------------------------------------------------------------------------------
nc, out, text = run(image(signed), TrainingSteps=150, OutputMode="Decoded, float32")
full, _ = decoded_values(out)
steps_before = nvtest.field_value(out, "NeuralSteps")
psnr_before = nvtest.field_value(out, "NeuralPSNR")
with nvtest.captured_messages() as messages:
    nc.OutputResolution = [17, 17, 17]
    nc.UpdatePipeline()
    coarse_out = servermanager.Fetch(nc)
coarse, _ = decoded_values(coarse_out)
check(coarse_out.GetDimensions() == (17, 17, 17) and coarse is not None and coarse.size == 17 ** 3,
      "OutputResolution 17^3: the output has the new dimensions (%r)" % (coarse_out.GetDimensions(),))
check(nvtest.field_value(coarse_out, "NeuralSteps") == steps_before == 150 and "steps in" not in messages[0],
      "OutputResolution: no training (steps %r, before %r; %s)" % (nvtest.field_value(coarse_out, "NeuralSteps"),
                                                                    steps_before, messages[0].strip()[-200:]))
check(nvtest.field_value(coarse_out, "NeuralPSNR") == psnr_before, "OutputResolution: the same network's PSNR")
every_other = full.reshape(N, N, N)[::2, ::2, ::2].ravel()
diff = float(np.abs(coarse - every_other).max()) if coarse is not None and coarse.size == every_other.size else math.inf
check(diff <= 1e-6, "OutputResolution 17^3: every other sample of the 33^3 decode (max difference %.3g)" % diff)
p_coarse, _, _ = measure(coarse, signed.reshape(N, N, N)[::2, ::2, ::2].ravel())
log("OutputResolution 17^3: %d steps, max difference to the 33^3 decode %.3g, PSNR there %.2f dB" %
    (steps_before, diff, p_coarse))
nc.OutputResolution = [0, 0, 0]
nc.UpdatePipeline()
again, _ = decoded_values(servermanager.Fetch(nc))
check(nvtest.field_value(servermanager.Fetch(nc), "NeuralSteps") == 150 and np.array_equal(again, full),
      "OutputResolution back to 0 0 0: the same decode, no training")
rows.append(("OutputResolution 33^3 -> 17^3 -> 0 0 0", "re-decoded, not retrained",
             "150 steps before and after; max difference to every other sample %.3g" % diff))
Delete(nc)

for r in rows:
    log("| " + " | ".join(r) + " |")
nvtest.finish()
