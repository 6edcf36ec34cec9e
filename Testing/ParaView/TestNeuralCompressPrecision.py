"""Precision of Neural Compress's figures and decoded output, each PSNR measured independently with numpy: a float64
field 1e-7 wide around 1e6 and one of magnitude 1e-300 are decoded in float64 (also when float32 output was asked
for, with a warning, since float32 cannot hold them); an int64 field around 2^40 keeps its precision in its own type;
a range wider than the largest double (+-1.2e308: max - min = inf) is normalised on halves (Cuda/Core/ValueRange.h):
it trains, decodes in float64, finite, with the PSNR of the same field at +-1.2, never NaN or +inf dB.
Thresholds are the measured values on the CPU engine (2 threads, 200 steps) minus a margin."""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
N = 24
Z, Y, X = np.meshgrid(*(np.linspace(-1, 1, N),) * 3, indexing="ij")
BASE = np.sin(3 * X) * np.cos(2 * Y) + 0.5 * Z


def compress(values, mode):
    with nvtest.captured_messages() as messages:
        nc = NeuralCompress(Input=nvtest.point_image(values, (N, N, N)), SelectInputScalars=["POINTS", "f"], TrainingSteps=200, Device="CPU",
                            Threads=2, TrainInBackground=0, OutputMode=mode, Log2TableSize=14, BatchSize=16384,
                            Deterministic=1)
        nc.UpdatePipeline()
        out = servermanager.Fetch(nc)
    Delete(nc)
    return out, messages[0]


def numpy_psnr(decoded, values):
    # In extended precision (80-bit on x86-64): differences and the range stay finite up to 2 * DBL_MAX.
    v = values.ravel().astype(np.longdouble)
    d = decoded.astype(np.longdouble)
    rng = v.max() - v.min()
    mse = float(np.mean(((d - v) / rng) ** 2))
    return 10 * math.log10(1.0 / mse) if mse > 0 else float("inf")


def relative_max_error(decoded, values):
    v = values.ravel().astype(np.longdouble)
    return float(np.abs(decoded.astype(np.longdouble) - v).max() / (v.max() - v.min()))


for name, values in (("1e-7 wide around 1e6", 1e6 + 1e-7 * BASE), ("magnitude 1e-300", 1e-300 * BASE)):
    for mode in ("Decoded, input type", "Decoded, float32"):
        out, text = compress(values.astype(np.float64), mode)
        arr = out.GetPointData().GetArray("f")
        psnr = numpy_psnr(vtk_to_numpy(arr), values) if arr else float("nan")
        reported = nvtest.field_value(out, "NeuralPSNR")
        log("%s, %s: %s output, PSNR %.2f dB (numpy), %s dB (filter)" % (name, mode, arr.GetDataTypeAsString() if arr
                                                                          else None, psnr, reported))
        check(arr is not None and arr.GetDataType() == 11, "%s, %s: float64 output" % (name, mode))
        check(psnr > 30.0 and abs(psnr - reported) < 0.05, "%s, %s: PSNR > 30 dB and as reported (%.2f, %s)"
              % (name, mode, psnr, reported))
        # Within its own tolerance: the worst sample off by less than a quarter of the field's own range.
        rel = relative_max_error(vtk_to_numpy(arr), values) if arr else float("nan")
        check(rel < 0.25, "%s, %s: max error %.3f of the range (< 0.25)" % (name, mode, rel))
        if mode == "Decoded, float32":
            check("float32 cannot hold the values" in text, "%s: the float64 output is announced" % name)

# int64 around 2^40 with a range of 2^20: float32 would keep 2^16 steps of it, the int64 output keeps it all.
big = (2 ** 40 + np.round((2 ** 20) * (BASE + 1.5))).astype(np.int64)
out, text = compress(big, "Decoded, input type")
arr = out.GetPointData().GetArray("f")
psnr = numpy_psnr(vtk_to_numpy(arr), big) if arr else float("nan")
log("int64 around 2^40: %s output, PSNR %.2f dB (numpy), %s dB (filter)"
    % (arr.GetDataTypeAsString() if arr else None, psnr, nvtest.field_value(out, "NeuralPSNR")))
check(arr is not None and arr.GetDataTypeAsString() in ("long long", "long", "vtkIdType", "idtype")
      and psnr > 30.0, "int64: its own type, PSNR > 30 dB (%.2f)" % psnr)
check(abs(psnr - nvtest.field_value(out, "NeuralPSNR")) < 0.05, "int64: the reported PSNR is the measured one")

# A range wider than the largest double: trained and decoded as the same field at +-1.2 (the normalised values are the
# same to rounding), in float64, every value finite; the filter's figures finite and the measured ones.
unit = BASE / np.abs(BASE).max()
results = {}
for name, scale in (("+-1.2", 1.2), ("+-1.2e308", 1.2e308)):
    out, text = compress(unit * scale, "Decoded, input type")
    arr = out.GetPointData().GetArray("f")
    decoded = vtk_to_numpy(arr) if arr else None
    psnr = numpy_psnr(decoded, unit * scale) if arr else float("nan")
    reported, max_error = nvtest.field_value(out, "NeuralPSNR"), nvtest.field_value(out, "NeuralMaxError")
    log("%s: %s output, PSNR %.3f dB (numpy), %s dB (filter), max error %s" % (
        name, arr.GetDataTypeAsString() if arr else None, psnr, reported, max_error))
    check("ERROR" not in text and arr is not None and arr.GetDataType() == 11, "%s: float64 output, no error (%s)"
          % (name, text.strip()[-200:]))
    check(decoded is not None and bool(np.all(np.isfinite(decoded))), "%s: every decoded value finite" % name)
    check(reported is not None and math.isfinite(reported) and abs(psnr - reported) < 0.05
          and max_error is not None and math.isfinite(max_error), "%s: finite figures, the PSNR as measured (%s, %s)"
          % (name, reported, max_error))
    results[name] = (psnr, max_error if max_error is not None else math.nan)
check(results["+-1.2e308"][0] > 30.0 and abs(results["+-1.2e308"][0] - results["+-1.2"][0]) < 0.05,
      "+-1.2e308: PSNR > 30 dB, that of the same field at +-1.2 (%.3f, %.3f)"
      % (results["+-1.2e308"][0], results["+-1.2"][0]))
check(abs(results["+-1.2e308"][1] / 1e308 - results["+-1.2"][1]) <= 0.01 * results["+-1.2"][1],
      "+-1.2e308: max error that of +-1.2 scaled (%s, %s)" % (results["+-1.2e308"][1], results["+-1.2"][1]))

nvtest.finish()
