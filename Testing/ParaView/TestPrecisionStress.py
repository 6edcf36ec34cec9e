"""Neural Compress on odd inputs: NaN/Inf, a constant, ranges of 1e+-30 and 1e+-300, a range wider than the largest
double, narrow ranges around large offsets, 64-bit integers at their limits, every VTK scalar type, degenerate and
2-D extents. Each case is either a clear error (an exact message) or a result whose PSNR and max error, measured
here with numpy on the output against the input (relative to the input's range, in extended precision), meet the
case's threshold; the filter's own PSNR must agree with numpy's.

    pvbatch TestPrecisionStress.py [--table results.md]

writes the results as a Markdown table. Thresholds: the values measured on the CPU engine (2 threads, 150 steps,
24^3 samples: 32 to 35 dB) minus a margin of 4 to 7 dB."""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.util import vtkConstants as C  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
TABLE = sys.argv[sys.argv.index("--table") + 1] if "--table" in sys.argv else None

N = 24
SETTINGS = dict(TrainingSteps=150, Device="CPU", Threads=2, TrainInBackground=0, Levels=8, FeaturesPerLevel=2,
                Log2TableSize=12, NetworkWidth=32, BatchSize=4096, Deterministic=1, OutputMode="Decoded, input type")
LD = np.longdouble  # 80-bit on x86-64: differences of doubles up to 2 * DBL_MAX stay finite


def base(dims):
    """A smooth field in [-1.5, 1.5] on dims (x, y, z), in VTK order (x fastest)."""
    axes = [np.linspace(-1, 1, d) if d > 1 else np.zeros(1) for d in dims]
    Z, Y, X = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return (np.sin(3 * X) * np.cos(2 * Y) + 0.5 * Z).ravel()


def unit(dims):
    """base() mapped onto [0, 1] exactly (min 0, max 1)."""
    b = base(dims)
    return (b - b.min()) / (b.max() - b.min())


def integers(dims, lo, hi, dtype):
    """An integer field from exactly lo to exactly hi (Python integers: exact also at the 64-bit limits)."""
    t = unit(dims)
    span = hi - lo
    return np.array([lo + int(round(float(x) * span)) if x < 1 else hi for x in t], dtype=dtype)


def measure(decoded, values):
    """(PSNR dB, max |error|, max |error| / range) over the finite input samples, in extended precision."""
    v, d = values.ravel(), decoded.ravel()
    ok = np.isfinite(v.astype(np.float64)) if v.dtype.kind == "f" else np.ones(v.size, bool)
    if v.dtype.kind in "iu":
        diff = np.array([int(a) - int(b) for a, b in zip(d[ok], v[ok])], dtype=LD) if d.dtype.kind in "iu" \
            else d[ok].astype(LD) - np.array([int(b) for b in v[ok]], dtype=LD)
        width = LD(int(v.max()) - int(v.min()))
    else:
        diff = d[ok].astype(LD) - v[ok].astype(LD)
        width = v[ok].astype(LD).max() - v[ok].astype(LD).min()
    maxerr = float(np.abs(diff).max()) if diff.size else 0.0
    if width == 0:
        mse = float(np.mean(diff.astype(np.float64) ** 2))
        return (math.inf if mse == 0 else 10 * math.log10(1.0 / mse) if mse > 0 else math.nan), maxerr, maxerr
    rel = diff / width
    mse = float(np.mean(rel * rel))
    psnr = math.inf if mse == 0 else 10 * math.log10(1.0 / mse) if mse > 0 else math.nan
    return psnr, maxerr, float(np.abs(rel).max())


def describe_range(values):
    v = values.ravel()
    if v.dtype.kind == "f":
        v = v[np.isfinite(v)]
    if v.size == 0:
        return "-"
    if v.dtype.kind in "iu":
        return "%d .. %d" % (int(v.min()), int(v.max()))
    lo, hi = float(v.min()), float(v.max())
    digits = 6 if not (hi > lo) or abs(hi - lo) > 1e-3 * max(abs(lo), abs(hi)) else 15  # narrow: enough digits
    return "%.*g .. %.*g" % (digits, lo, digits, hi)


rows = []


def case(name, values, dims=(N, N, N), vtk_type=None, psnr=None, error=None, out_type=None, exact=False):
    """Run one case. psnr: the least PSNR (dB) by numpy; error: the expected message (then the output is empty);
    out_type: the expected output array type name; exact: the decoded values equal the input."""
    producer = nvtest.point_image(values, dims, vtk_type=vtk_type)
    in_array = producer.GetClientSideObject().GetOutputDataObject(0).GetPointData().GetArray("f")
    in_type = in_array.GetDataTypeAsString() if in_array is not None else "-"
    with nvtest.captured_messages() as messages:
        nc = NeuralCompress(Input=producer, **SETTINGS)
        if values is not None:
            nc.SelectInputScalars = ["POINTS", "f"]
        nc.UpdatePipeline()
        out = servermanager.Fetch(nc)
    Delete(nc)
    Delete(producer)
    text = messages[0]
    arr = out.GetPointData().GetArray("f")
    rng = describe_range(values) if values is not None else "-"
    if error is not None:
        ok = check(error in text and "ERROR" in text, "%s: the error %r (got %r)" % (name, error, text.strip()[-300:]))
        check(arr is None and out.GetFieldData().GetArray("NeuralNetwork") is None
              and nvtest.field_value(out, "NeuralPSNR") is None, "%s: an empty output" % name)
        rows.append((name, in_type, rng, "error: " + error if ok else "UNEXPECTED", "-", "-", "-"))
        log("%-34s error as expected: %s" % (name, error))
        return
    check("ERROR" not in text, "%s: no error (%r)" % (name, text.strip()[-300:]))
    if arr is None:
        check(False, "%s: a decoded output" % name)
        rows.append((name, in_type, rng, "NO OUTPUT", "-", "-", "-"))
        return
    decoded = vtk_to_numpy(arr)
    p, maxerr, relerr = measure(decoded, values)
    reported = nvtest.field_value(out, "NeuralPSNR")
    out_name = arr.GetDataTypeAsString()
    log("%-34s %-18s %-14s PSNR %7.2f dB (filter %s), max error %.4g (%.2e of the range)"
        % (name, in_type, out_name, p, reported, maxerr, relerr))
    check(decoded.size == values.size, "%s: one decoded value per sample" % name)
    check(decoded.dtype.kind in "iu" or bool(np.all(np.isfinite(decoded))), "%s: decoded values all finite" % name)
    good = p >= psnr and math.isfinite(maxerr)
    if exact:
        good = good and bool(np.array_equal(decoded, values))
    check(good, "%s: PSNR %.2f >= %.1f dB, max error finite (%.4g)%s" % (name, p, psnr, maxerr,
                                                                         ", exact" if exact else ""))
    check(reported is not None and not math.isnan(reported)
          and (abs(p - reported) < 0.05 or (math.isinf(p) and p == reported)),
          "%s: the filter's PSNR (%s) is numpy's (%.3f)" % (name, reported, p))
    if out_type is not None:
        check(out_name in out_type, "%s: %s output (got %s)" % (name, out_type, out_name))
    rows.append((name, in_type, rng, "trained (>= %g dB)" % psnr if not exact else "exact", out_name,
                 "%.2f" % p if math.isfinite(p) else "inf", "%.3g (%.1e)" % (maxerr, relerr)))


CUBE = (N, N, N)
F64, F32 = np.float64, np.float32

# NaN / Inf samples: excluded from training, decoded to finite values; measured over the finite ones.
holes = base(CUBE).astype(F32)
holes[::97], holes[5::211], holes[7::307] = np.nan, np.inf, -np.inf
case("NaN / Inf samples", holes, psnr=28.0)
case("all NaN", np.full(N ** 3, np.nan, F32), error="are NaN or Inf; nothing to train on")
case("constant", np.full(N ** 3, 3.25, F64), psnr=math.inf, exact=True)

# Magnitudes and widths of range.
for label, scale, dtype in (("1e+30 range", 1e30, F64), ("1e-30 range", 1e-30, F64), ("1e+300 range", 1e300, F64),
                            ("1e-300 range", 1e-300, F64), ("1e+30 range, float32", 1e30, F32),
                            ("1e-30 range, float32", 1e-30, F32)):
    case(label, (scale * base(CUBE)).astype(dtype), psnr=28.0, out_type="double" if dtype == F64 else "float")
case("+-1.5e308 (max - min = inf)", base(CUBE) / 1.5 * 1.5e308, psnr=28.0, out_type="double")
case("-DBL_MAX .. DBL_MAX", np.finfo(F64).max * (2 * unit(CUBE) - 1), psnr=28.0, out_type="double")
case("1e-7 wide around 1e6", 1e6 + 1e-7 * base(CUBE), psnr=28.0, out_type="double")
case("1e-3 wide around -1e10", -1e10 + 1e-3 * base(CUBE), psnr=28.0, out_type="double")

# 64-bit integers at their limits, and narrow near them.
I64, U64 = np.iinfo(np.int64), np.iinfo(np.uint64)
case("int64, full range", integers(CUBE, int(I64.min), int(I64.max), np.int64), psnr=28.0,
     out_type=("long long", "long"))
case("uint64, full range", integers(CUBE, 0, int(U64.max), np.uint64), psnr=28.0,
     out_type=("unsigned long long", "unsigned long"))
case("int64, 2^24 wide below the max", integers(CUBE, int(I64.max) - 2 ** 24, int(I64.max), np.int64), psnr=28.0,
     out_type=("long long", "long"))
case("uint64, 2^24 wide below the max", integers(CUBE, int(U64.max) - 2 ** 24, int(U64.max), np.uint64), psnr=28.0,
     out_type=("unsigned long long", "unsigned long"))

# Every VTK scalar type, over most of its range; the output keeps the type.
for name, vtk_type, dtype, lo, hi in (
        ("char", C.VTK_CHAR, np.int8, -100, 100), ("signed char", C.VTK_SIGNED_CHAR, np.int8, -120, 120),
        ("unsigned char", C.VTK_UNSIGNED_CHAR, np.uint8, 0, 250), ("short", C.VTK_SHORT, np.int16, -30000, 30000),
        ("unsigned short", C.VTK_UNSIGNED_SHORT, np.uint16, 0, 60000),
        ("int", C.VTK_INT, np.int32, -2 ** 31, 2 ** 31 - 1), ("unsigned int", C.VTK_UNSIGNED_INT, np.uint32, 0, 2 ** 32 - 1),
        ("long", C.VTK_LONG, np.int64, -2 ** 62, 2 ** 62), ("unsigned long", C.VTK_UNSIGNED_LONG, np.uint64, 0, 2 ** 63),
        ("long long", C.VTK_LONG_LONG, np.int64, -10 ** 15, 10 ** 15),
        ("unsigned long long", C.VTK_UNSIGNED_LONG_LONG, np.uint64, 0, 10 ** 15)):
    case(name, integers(CUBE, lo, hi, dtype), vtk_type=vtk_type, psnr=28.0, out_type=name)
case("float", (100.0 * base(CUBE)).astype(F32), psnr=28.0, out_type="float")
case("double", (100.0 * base(CUBE)).astype(F64), psnr=28.0, out_type="double")

# Degenerate and 2-D extents.
for label, dims in (("2-D, 24 x 24 x 1", (N, N, 1)), ("2-D, 24 x 1 x 24", (N, 1, N)), ("2-D, 1 x 24 x 24", (1, N, N)),
                    ("1-D, 24 x 1 x 1", (N, 1, 1)), ("1-D, 1 x 1 x 24", (1, 1, N))):
    case(label, base(dims).astype(F32), dims=dims, psnr=28.0)
case("single point", np.array([7.0], F32), dims=(1, 1, 1), psnr=math.inf, exact=True)
case("empty extent", None, dims=None, error="empty extent")

if TABLE:
    with open(TABLE, "w") as f:
        f.write("# Neural Compress on odd inputs (Testing/ParaView/TestPrecisionStress.py)\n\n")
        f.write("CPU engine, %d threads, %d steps, %d^3 samples unless stated (Levels %d, 2^%d table, width %d, batch "
                "%d), output in the input's type. PSNR and max error by numpy on the output against the input, "
                "relative to the input's range, in extended precision; the filter's own PSNR agrees within 0.05 dB "
                "in every trained case.\n\n" % (SETTINGS["Threads"], SETTINGS["TrainingSteps"], N,
                                                  SETTINGS["Levels"], SETTINGS["Log2TableSize"],
                                                  SETTINGS["NetworkWidth"], SETTINGS["BatchSize"]))
        f.write("| case | input type | range | outcome | output type | PSNR by numpy (dB) | max error (of the range) |\n")
        f.write("|---|---|---|---|---|---|---|\n")
        for r in rows:
            f.write("| " + " | ".join(r) + " |\n")
    log("wrote %s" % TABLE)
nvtest.finish()
