"""Neural Compress's Sampling = Probe on inputs that are not images: the training targets are a bank of random points
probed inside the source's cells (VTK's probe with a static cell locator), not the trilinear interpolation of the
resampled image, so a field whose detail is finer than the automatic image is learned closer to the source. Checks:
a graded rectilinear grid with a sharp front where its cells are fine (generated, always runs) trains well with
Probe; disk_out_ref (real data, when NV_DATA_DIR has it) reaches a higher PSNR at its own points with Probe than with
Resample at the same steps; the bank is described (points inside the domain of those probed); the domain stays NaN outside; Sampling is
part of the training (switching it trains, switching back reuses nothing stale) and does not apply to images (their
network is the same bit for bit). Thresholds are the measured values on the CPU engine (Deterministic, 2 threads)
minus a margin."""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkRectilinearGrid  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
COMMON = dict(TrainingSteps=300, BatchSize=16384, Device="CPU", Threads=2, Deterministic=1, Log2TableSize=14,
              TrainInBackground=0)


def fd(data, name):
    a = data.GetFieldData().GetArray(name)
    return a.GetValue(0) if a else None


def compress(name, src, array, **extra):
    with nvtest.captured_messages() as messages:
        nc = NeuralCompress(Input=src, SelectInputScalars=["POINTS", array], **dict(COMMON, **extra))
        nc.UpdatePipeline()
        out = servermanager.Fetch(nc)
    nc.UpdatePropertyInformation()
    text = " ".join(messages[0]) if isinstance(messages[0], list) else str(messages[0])
    log("%s (%s): PSNR at %s source samples %s dB, on the image %s dB; %s"
        % (name, extra.get("Sampling", "Resample"), fd(out, "NeuralSourceSamples"), fd(out, "NeuralPSNR"),
           fd(out, "NeuralResampledPSNR"), text.strip()[:400]))
    return nc, out, text


# 1. A rectilinear grid graded towards x = 0, where a tanh front 0.04 wide sits (its cells there are 5x finer than
#    the automatic image's spacing). Measured at the grid's points after 300 CPU steps: Probe 32.5 dB; Resample 34.7 dB
#    with KeepBestNetwork (its best probe, step 200; its last network, 27.3 dB, had wandered off). So no ranking is
#    asserted on this case -- disk_out_ref below, and the GPU curves of results/probe_2026-11-24.md, are where Probe
#    wins -- only that Probe trains it well, with its bank reported.
xs = np.concatenate([np.linspace(-1.0, -0.11, 10), np.linspace(-0.1, 0.1, 30), np.linspace(0.11, 1.0, 10)])
ys = np.linspace(-1.0, 1.0, 10)
zs = np.linspace(-0.5, 0.5, 8)
rect = vtkRectilinearGrid()
rect.SetDimensions(len(xs), len(ys), len(zs))
for setter, v in ((rect.SetXCoordinates, xs), (rect.SetYCoordinates, ys), (rect.SetZCoordinates, zs)):
    setter(numpy_to_vtk(v.astype(np.float64), deep=True))
Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")
values = numpy_to_vtk((np.tanh(X / 0.04) + 0.3 * Y + 0.2 * Z).astype(np.float32).ravel(), deep=True)
values.SetName("front")
rect.GetPointData().AddArray(values)
path = os.path.join(nvtest.output_dir(), "probe_front.vtr")
from vtkmodules.vtkIOXML import vtkXMLRectilinearGridWriter  # noqa: E402
w = vtkXMLRectilinearGridWriter()
w.SetInputData(rect)
w.SetFileName(path)
check(w.Write() == 1, "wrote " + path)
src = OpenDataFile(path)

rs, rs_out, _ = compress("graded front", src, "front", FinestResolution=256)
pr, pr_out, pr_text = compress("graded front", src, "front", FinestResolution=256, Sampling="Probe")
p_rs, p_pr = fd(rs_out, "NeuralPSNR"), fd(pr_out, "NeuralPSNR")
check(fd(pr_out, "NeuralSourceSamples") == rect.GetNumberOfPoints(), "front: measured at all %d source points"
      % rect.GetNumberOfPoints())
check(p_pr is not None and p_pr > 31.0 and p_rs is not None and p_rs > 31.0,
      "front: Probe and Resample > 31 dB at the source points (%s, %s)" % (p_pr, p_rs))
m = re.search(r"Probe: (\d+) of (\d+) random points inside the domain", pr_text)
check(m is not None and int(m.group(2)) == 1 << 20 and int(m.group(1)) == 1 << 20,
      "front: the bank is reported, all 2^20 probed points inside the box-shaped domain (%s)"
      % (m.group(0) if m else pr_text[:200]))
check(pr_out.GetDimensions() == rs_out.GetDimensions(), "front: the same output image in both modes")
steps_before = pr.GetPropertyValue("TotalStepsTrained")
pr.ProbePoints = 1 << 18
pr.TrainingSteps = 100
pr.UpdatePipeline()
pr.UpdatePropertyInformation()
check(pr.GetPropertyValue("TotalStepsTrained") == steps_before + 100, "front: another bank size trains again")
p_small = fd(servermanager.Fetch(pr), "NeuralPSNR")
log("front: Probe with a bank of 2^18 points: %s dB" % p_small)
check(p_small is not None and p_small > 20.0, "front: a 2^18 bank trains (%s dB)" % p_small)
Delete(pr)
Delete(rs)

# 2. Images are their own samples: Sampling does not apply, the decoded field is the same bit for bit.
wav = Wavelet(WholeExtent=[0, 23, 0, 23, 0, 23])
a, a_out, _ = compress("wavelet", wav, "RTData", Log2TableSize=12, TrainingSteps=50, OutputMode="Decoded, float32")
b, b_out, _ = compress("wavelet", wav, "RTData", Log2TableSize=12, TrainingSteps=50, OutputMode="Decoded, float32",
                       Sampling="Probe")
na = vtk_to_numpy(a_out.GetPointData().GetArray("RTData"))
nb = vtk_to_numpy(b_out.GetPointData().GetArray("RTData"))
check(na.shape == nb.shape and (na == nb).all(), "image input: Sampling Probe gives the same decoded field bit for bit")
Delete(a)
Delete(b)

# 3. disk_out_ref: the unstructured grid is refined near the disk, where the automatic 52 x 52 x 90 image is coarser
#    than the cells (measured: Resample 35.5 dB with KeepBestNetwork -- 34.7 dB without --, Probe 39.3 dB at its 8499
#    points after 300 steps).
data_dir = os.environ.get("NV_DATA_DIR", "")
disk_file = os.path.join(data_dir, "disk_out_ref", "disk_out_ref.ex2")
if os.path.exists(disk_file):
    disk = ExodusIIReader(FileName=disk_file, PointVariables=["Temp"])
    r, r_out, _ = compress("disk_out_ref", disk, "Temp")
    p, p_out, p_text = compress("disk_out_ref", disk, "Temp", Sampling="Probe", OutputMode="Decoded, float32")
    d_r, d_p = fd(r_out, "NeuralPSNR"), fd(p_out, "NeuralPSNR")
    check(d_p > 37.0 and d_p > d_r + 3.0, "disk_out_ref: Probe > 37 dB and 3 dB above Resample (%s vs %s)"
          % (d_p, d_r))
    m = re.search(r"Probe: (\d+) of (\d+) random points inside the domain", p_text)
    inside = int(m.group(1)) / float(m.group(2)) if m else 0.0
    # The reactor is a cylinder with a hollow inside its bounding box: about 61% of the box is inside a cell.
    check(0.55 < inside < 0.67, "disk_out_ref: the bank keeps only points inside the cells (%.3f of them)" % inside)
    decoded = vtk_to_numpy(p_out.GetPointData().GetArray("Temp"))
    check(np.isnan(decoded).any() and np.isfinite(decoded).any(),
          "disk_out_ref: the decoded output is NaN outside the domain, finite inside")
else:
    log("disk_out_ref not found under NV_DATA_DIR=%r: the real-data part is skipped" % data_dir)

nvtest.finish()
