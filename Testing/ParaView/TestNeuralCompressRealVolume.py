"""Neural Compress on real CT / density volumes read from .nhdr (detached NRRD header) files:
headsq (int16, 64x64x93) and bucky (uint8, 32^3). SKIPs when the data folder is absent."""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

data_dir = os.environ.get("NV_DATA_DIR", "")
HEADSQ = os.path.join(data_dir, "headsq", "headsq_64x64x93_int16.nhdr")
BUCKY = os.path.join(data_dir, "bucky", "bucky_32x32x32_uint8.nhdr")
if not (data_dir and os.path.exists(HEADSQ) and os.path.exists(BUCKY)):
    nvtest.skip("real data sets not found under NV_DATA_DIR=%r" % data_dir)

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log

FAST = dict(BatchSize=16384, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2,
            Loss="L2", Threads=2, PSNRInterval=100, TargetCompressionRatio=10)

# name, file, dims, numpy type, steps, PSNR threshold (dB; measured values in the comments)
CASES = [
    ("headsq", HEADSQ, (64, 64, 93), np.int16, 400, 27.0),  # measured 28.9 dB
    ("bucky", BUCKY, (32, 32, 32), np.uint8, 300, 23.0),  # measured 25.3 dB
]

for name, path, dims, dtype, steps, threshold in CASES:
    reader = NrrdReader(FileName=path)
    reader.UpdatePipeline()
    source = servermanager.Fetch(reader)
    array_name = source.GetPointData().GetArrayName(0)
    check(source.GetDimensions() == dims, "%s: reader gives %r" % (name, source.GetDimensions()))
    original = vtk_to_numpy(source.GetPointData().GetArray(0))
    check(original.dtype == dtype, "%s: native type %s" % (name, original.dtype))
    original = original.astype(np.float64)
    vmin, vmax = original.min(), original.max()

    nc = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", array_name], TrainingSteps=steps, **FAST)
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    psnr = nvtest.field_value(out, "NeuralPSNR")
    ratio = nvtest.field_value(out, "NeuralCompressionRatio")
    model_bytes = nvtest.field_value(out, "NeuralModelBytes")
    log("%s: %d steps in %.2f s, PSNR %.2f dB, max error %.1f, ratio %.2f"
        % (name, nvtest.field_value(out, "NeuralSteps"), nvtest.field_value(out, "NeuralTrainingSeconds"),
           psnr, nvtest.field_value(out, "NeuralMaxError"), ratio))
    check(psnr >= threshold, "%s: PSNR %.2f dB >= %.1f dB" % (name, psnr, threshold))
    check(out.GetDimensions() == dims and np.allclose(out.GetBounds(), source.GetBounds()),
          "%s: output on the input geometry" % name)
    decoded = vtk_to_numpy(out.GetPointData().GetArray(array_name)).astype(np.float64)
    own = 10.0 * math.log10(1.0 / np.mean(((decoded - original) / (vmax - vmin)) ** 2))
    nvtest.check_close(psnr, own, 0.05, "%s: NeuralPSNR matches the decoded output" % name)
    raw = original.size * np.dtype(dtype).itemsize
    nvtest.check_close(ratio, raw / model_bytes, 1e-9 * ratio, "%s: ratio uses the native-type bytes" % name)
    if ratio >= 10.0:
        check(ratio < 2.2 * 10.0, "%s: the largest table that meets the target is used" % name)
        check("out of reach" not in messages[0], "%s: no ratio warning" % name)
    else:
        # 32 KiB of uint8 cannot be stored 10:1 by the smallest 2^10 table: a warning says so.
        check("target compression ratio 10:1 is out of reach" in messages[0],
              "%s: unreachable target reported (%r)" % (name, messages[0]))
        check("Float16" not in messages[0], "%s: the advice does not suggest what is on (%r)" % (name, messages[0]))
    Delete(nc)
    Delete(reader)

# The defaults never warn on the regular grids of the data folder (every .nhdr volume, and the OpenLB velocity
# series): the automatic size target is reachable or silently the smallest table, no advice about what is on.
# (TrainingSteps is lowered to keep the test short: it does not change the checks or messages.)
import glob  # noqa: E402
volumes = sorted(glob.glob(os.path.join(data_dir, "*", "*.nhdr")))
flow = os.path.join(data_dir, "voreen_openlb_flow_timeseries", "results_iT0010000iC00000.vti")
check(len(volumes) >= 7, "the regular-grid volumes are found (%d)" % len(volumes))
for path in volumes + ([flow] if os.path.exists(flow) else []):
    reader = NrrdReader(FileName=path) if path.endswith(".nhdr") else XMLImageDataReader(FileName=path)
    reader.UpdatePipeline()
    info = reader.GetDataInformation().DataInformation.GetPointDataInformation()
    nc = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", info.GetArrayInformation(0).GetName()],
                        TrainingSteps=2, TrainInBackground=0, OutputMode="Network only")
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    log("defaults, %s: ratio %.2f, no warning: %s" % (os.path.basename(path),
        nvtest.field_value(out, "NeuralCompressionRatio"), "Warning" not in messages[0]))
    check("Warning" not in messages[0] and "WARN" not in messages[0],
          "defaults on %s: no warning (%r)" % (os.path.basename(path), messages[0][:300]))
    Delete(nc)
    Delete(reader)

nvtest.finish()
