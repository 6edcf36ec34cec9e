"""MaxError (the error-bounded mode) on a 48^3 Wavelet trained briefly on the CPU (Deterministic): with the bound at
1% and 0.3% of the range, every voxel of the decoded output (float32 and the input's type), checked with numpy, is
within the bound, where the same network without the mode misses it by several times; the output says the bound and
the number of corrections; the ratio counts the correction list (model bytes = the network's + the list's); the
network is format version 5 and a .nvol saved and read back decodes to the same bounded values; 8-bit storage keeps
the bound too. Absurd bounds: a negative or NaN MaxError is refused with a warning (the mode off, the output as
without it); a huge one needs no correction and costs the 40 bytes of the bound, count, size and two empty streams."""
import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
out_dir = nvtest.output_dir()

RUN = dict(TrainingSteps=150, BatchSize=8192, Levels=8, FeaturesPerLevel=2, Log2TableSize=12, NetworkWidth=32,
           HiddenLayers=2, Threads=2, Seed=1, Device="CPU", Deterministic=1, PSNRInterval=0)

wavelet = Wavelet(WholeExtent=[-23, 24, -23, 24, -23, 24])
original = vtk_to_numpy(servermanager.Fetch(wavelet).GetPointData().GetArray("RTData")).astype(np.float64)
vmin, vmax = original.min(), original.max()


def net_bytes(data):
    a = data.GetFieldData().GetArray("NeuralNetwork")
    return bytes(vtk_to_numpy(a).tobytes()) if a is not None else None


def field(out, name):
    a = out.GetFieldData().GetArray(name)
    return a.GetValue(0) if a is not None else None


def run(bound, precision="Float16", mode="Decoded, float32"):
    with nvtest.captured_messages() as messages:  # a refused bound warns when it is set
        nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], StoragePrecision=precision,
                            OutputMode=mode, MaxError=bound, **RUN)
        nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    decoded = vtk_to_numpy(out.GetPointData().GetArray("RTData")).astype(np.float64)
    r = dict(proxy=nc, out=out, text=messages[0], decoded=decoded,
             max_error=float(np.max(np.abs(decoded - original))), ratio=field(out, "NeuralCompressionRatio"),
             bytes=field(out, "NeuralModelBytes"), bound=field(out, "NeuralErrorBound"),
             corrections=field(out, "NeuralCorrections"), reported=field(out, "NeuralMaxError"))
    log("MaxError %r (%s, %s): ratio %.3f:1, %d bytes, max error %.4g (reported %.4g), bound %r, %r corrections"
        % (bound, precision, mode, r["ratio"], r["bytes"], r["max_error"], r["reported"], r["bound"],
           r["corrections"]))
    return r


plain = run(0.0)
check(plain["bound"] is None and plain["corrections"] is None, "no bound in the output when the mode is off")
check("ERROR" not in plain["text"] and "Warning" not in plain["text"], "a clean run: %r" % plain["text"])
network_bytes = plain["bytes"]
for fraction in (0.01, 0.003):
    bound = fraction * (vmax - vmin)
    r = run(bound)
    check("ERROR" not in r["text"] and "Warning" not in r["text"], "a clean run: %r" % r["text"])
    check(plain["max_error"] > 3 * bound, "the network alone misses the bound %.4g: max error %.4g"
          % (bound, plain["max_error"]))
    check(np.all(np.abs(r["decoded"] - original) <= bound),
          "every voxel within the bound %.4g (max error %.4g)" % (bound, r["max_error"]))
    check(r["reported"] is not None and r["reported"] <= bound and abs(r["reported"] - r["max_error"]) < 1e-3 * bound,
          "NeuralMaxError %r is the decoded output's %.6g" % (r["reported"], r["max_error"]))
    check(r["bound"] == bound and r["corrections"] > 0, "the output says the bound and the corrections")
    network = net_bytes(r["out"])
    check(network[:8] == b"NVOLNET\0" and struct.unpack("<I", network[8:12])[0] == 5, "format version 5")
    # The list: 40 bytes (bound, count, size, two stream sizes) and two rANS-coded varint streams (an index step and a
    # value each: at most 2 bytes a correction here, plus the coders' tables).
    check(network_bytes + 40 < r["bytes"] <= network_bytes + 40 + 2 * r["corrections"] + 1024,
          "model bytes %d = network %d + the list of %d corrections" % (r["bytes"], network_bytes, r["corrections"]))
    check(abs(r["ratio"] - original.size * 4 / r["bytes"]) < 1e-6 * r["ratio"], "ratio = source bytes / model bytes")
    check("error bound" in r["text"], "the summary says the bound: %r" % r["text"])
    if fraction == 0.003:
        tight = r

# The input's type (float32 for the Wavelet) decodes the same bounded field.
typed = run(0.003 * (vmax - vmin), mode="Decoded, input type")
check(np.array_equal(typed["decoded"], tight["decoded"]), "the input-type output is the bounded float32 field")

# .nvol: saved and read back, the same network, the same bounded values.
path = os.path.join(out_dir, "wavelet_maxerror.nvol")
SaveData(path, proxy=tight["proxy"])
with nvtest.captured_messages() as messages:
    reader = NeuralVolumeReader(FileName=[path], OutputMode="Decoded, float32", Device="CPU")
    reader.UpdatePipeline()
    loaded = servermanager.Fetch(reader)
check("ERROR" not in messages[0], "reading gives no error (%s)" % messages[0].strip())
check(net_bytes(loaded) == net_bytes(tight["out"]), "the .nvol holds the filter's network bytes")
back = vtk_to_numpy(loaded.GetPointData().GetArray("RTData")).astype(np.float64)
check(np.array_equal(back, tight["decoded"]), "the file decodes to the filter's bounded values")
check(field(loaded, "NeuralCompressionRatio") == tight["ratio"], "the file's ratio counts the list")

# 8-bit storage keeps the bound.
q8 = run(0.01 * (vmax - vmin), precision="8-bit (entropy coded)")
check(np.all(np.abs(q8["decoded"] - original) <= 0.01 * (vmax - vmin)), "8-bit: every voxel within the bound")

# Absurd bounds.
for bad in (-1.0, float("nan")):
    r = run(bad)
    check("Warning" in r["text"] and "refused" in r["text"], "MaxError %r refused with a warning: %r" % (bad, r["text"]))
    check(r["bound"] is None and r["bytes"] == network_bytes and np.array_equal(r["decoded"], plain["decoded"]),
          "MaxError %r: the mode is off" % bad)
huge = run(1e30)
check(huge["bound"] == 1e30 and huge["corrections"] == 0 and huge["bytes"] == network_bytes + 40,
      "a huge bound: no correction, 40 bytes")
check(np.array_equal(huge["decoded"], plain["decoded"]), "a huge bound leaves the network's values")

nvtest.finish()
