"""StoragePrecision "8-bit (entropy coded)" (nv::Precision::Quantized8) on a 64^3 Wavelet: the same training as a
Float16 run (Deterministic, CPU) stored as 8-bit codes reports a ratio at least RATIO_FACTOR times the Float16 one and
a PSNR within PSNR_DROP dB of it; the reported PSNR is that of the decoded output (measured with numpy); the summary
names q8; the network is format version 4; a .nvol saved and read back carries the same network bytes and decodes
to the same values bit for bit. Bounds: measured on the CPU engine (2 threads, 300 steps) with a margin."""
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

# Measured: Float16 2.30:1, 42.26 dB; 8-bit 5.75:1 (2.50x), 42.23 dB.
RATIO_FACTOR = 2.2
PSNR_DROP = 0.3
RUN = dict(TrainingSteps=300, BatchSize=16384, Levels=8, FeaturesPerLevel=2, Log2TableSize=14, NetworkWidth=32,
           HiddenLayers=2, Loss="L2", Threads=2, Seed=1, Device="CPU", Deterministic=1, PSNRInterval=0)

wavelet = Wavelet(WholeExtent=[-31, 32, -31, 32, -31, 32])
original = vtk_to_numpy(servermanager.Fetch(wavelet).GetPointData().GetArray("RTData")).astype(np.float64)
vmin, vmax = original.min(), original.max()


def net_bytes(data):
    a = data.GetFieldData().GetArray("NeuralNetwork")
    return bytes(vtk_to_numpy(a).tobytes()) if a is not None else None


def run(precision):
    nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], StoragePrecision=precision, **RUN)
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    decoded = vtk_to_numpy(out.GetPointData().GetArray("RTData")).astype(np.float64)
    mse = np.mean(((decoded - original) / (vmax - vmin)) ** 2)
    r = dict(proxy=nc, out=out, text=messages[0], ratio=nvtest.field_value(out, "NeuralCompressionRatio"),
             psnr=nvtest.field_value(out, "NeuralPSNR"), bytes=nvtest.field_value(out, "NeuralModelBytes"),
             numpy_psnr=10 * math.log10(1.0 / mse), decoded=decoded)
    log("%s: ratio %.2f:1, %d bytes, PSNR %.3f dB (numpy %.3f)" % (precision, r["ratio"], r["bytes"], r["psnr"],
                                                                   r["numpy_psnr"]))
    return r


fp16 = run("Float16")
q8 = run("8-bit (entropy coded)")
check(q8["proxy"].GetPropertyValue("StoragePrecision") == "8-bit (entropy coded)", "the enumeration entry")
check("ERROR" not in q8["text"] and "Warning" not in q8["text"], "a clean run: %r" % q8["text"])
check("fp16" in fp16["text"] and "q8" in q8["text"], "the summary names the storage: %r" % q8["text"])
check(q8["ratio"] >= RATIO_FACTOR * fp16["ratio"],
      "8-bit ratio %.2f >= %.1f x the Float16 ratio %.2f" % (q8["ratio"], RATIO_FACTOR, fp16["ratio"]))
check(abs(q8["ratio"] - original.size * 4 / q8["bytes"]) < 1e-6 * q8["ratio"], "ratio = source bytes / model bytes")
check(q8["psnr"] >= fp16["psnr"] - PSNR_DROP and fp16["psnr"] > 25.0,
      "8-bit PSNR %.3f within %.2f dB of Float16's %.3f" % (q8["psnr"], PSNR_DROP, fp16["psnr"]))
for r in (fp16, q8):
    check(abs(r["psnr"] - r["numpy_psnr"]) < 0.01, "reported PSNR %.4f is the decoded output's %.4f (numpy)"
          % (r["psnr"], r["numpy_psnr"]))
check(not np.array_equal(fp16["decoded"], q8["decoded"]), "the 8-bit output is the quantised network's")
network = net_bytes(q8["out"])
check(network[:8] == b"NVOLNET\0" and struct.unpack("<I", network[8:12])[0] == 4, "the network is format version 4")
check(len(network) < q8["bytes"] + 400, "the stored network (%d bytes) is the coded parameters (%d) and a header"
      % (len(network), q8["bytes"]))

# .nvol: Save Data -> NeuralVolumeReader gives the same network and the same decoded values.
path = os.path.join(out_dir, "wavelet_q8.nvol")
SaveData(path, proxy=q8["proxy"])
with nvtest.captured_messages() as messages:
    reader = NeuralVolumeReader(FileName=[path], OutputMode="Decoded, float32", Device="CPU")
    reader.UpdatePipeline()
    loaded = servermanager.Fetch(reader)
check("ERROR" not in messages[0], "reading gives no error (%s)" % messages[0].strip())
check(net_bytes(loaded) == network, "the .nvol holds the filter's network bytes")
a = vtk_to_numpy(q8["out"].GetPointData().GetArray("RTData"))
b = vtk_to_numpy(loaded.GetPointData().GetArray("RTData"))
check(a.dtype == b.dtype == np.float32 and np.array_equal(a, b), "the file decodes to the filter's values bit for bit")
for name in ("NeuralPSNR", "NeuralCompressionRatio", "NeuralModelBytes"):
    x, y = q8["out"].GetFieldData().GetArray(name), loaded.GetFieldData().GetArray(name)
    check(x is not None and y is not None and x.GetValue(0) == y.GetValue(0), "field data %s carried over" % name)

nvtest.finish()
