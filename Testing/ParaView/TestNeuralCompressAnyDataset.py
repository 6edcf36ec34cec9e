"""Neural Compress on datasets that are not images: they are resampled onto an image covering their bounds (VTK's
vtkResampleToImage), points outside the domain are never trained on and decode to NaN, one network represents the
union of a composite's blocks, and the final PSNR is measured at the source's own points or cells (the network
evaluated there), not on the resampled image. Generated cases (rectilinear, curvilinear structured, a multiblock of
two images, planar and curved poly data) always run; the real data sets (disk_out_ref, mug, Enzo AMR, CTH SpyPlot
AMR) run when NV_DATA_DIR has them. Thresholds are the measured values on the CPU engine (Deterministic, 2 threads)
minus a margin."""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonCore import vtkPoints  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkMultiBlockDataSet, vtkRectilinearGrid, vtkStructuredGrid  # noqa: E402,E501

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
# A 2^14 table: these fields are smaller than any model, so the automatic size (10:1 where reachable, else the
# smallest table) would pick 2^10, whose hash collisions cap the PSNR near 24 dB here.
COMMON = dict(TrainingSteps=300, BatchSize=16384, Device="CPU", Threads=2, Deterministic=1, Log2TableSize=14)


def fd_value(data, name):
    a = data.GetFieldData().GetArray(name)
    return a.GetValue(0) if a else None


def field(x, y, z):
    return np.sin(3.0 * x) * np.cos(2.0 * y) + 0.5 * np.exp(-((x - 0.3) ** 2 + y ** 2 + (z - 0.2) ** 2) / 0.3)


def producer(dataset, name):
    """A reader of `dataset`, written to the output folder in VTK's XML format."""
    from vtkmodules.vtkIOXML import vtkXMLDataObjectWriter, vtkXMLMultiBlockDataWriter
    path = os.path.join(nvtest.output_dir(), name)
    writer = vtkXMLMultiBlockDataWriter() if dataset.IsA("vtkMultiBlockDataSet") else vtkXMLDataObjectWriter()
    writer.SetInputData(dataset)
    writer.SetFileName(path)
    check(writer.Write() == 1, "wrote " + path)
    return OpenDataFile(path)


def compress(name, src, array, association="POINTS", time=None, **extra):
    nc = NeuralCompress(Input=src, SelectInputScalars=[association, array], **dict(COMMON, **extra))
    nc.UpdatePipeline(time) if time is not None else nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    psnr, resampled = fd_value(out, "NeuralPSNR"), fd_value(out, "NeuralResampledPSNR")
    samples, ratio = fd_value(out, "NeuralSourceSamples"), fd_value(out, "NeuralCompressionRatio")
    log("%s: output %s, PSNR at %s source samples %s dB (resampled image %s dB), ratio %s"
        % (name, out.GetDimensions(), samples, psnr, resampled, ratio))
    return nc, out, psnr, samples


# 1. A rectilinear grid with uneven spacing: covers its bounds, so nothing is outside; one network, the PSNR at its
#    own points.
xs = np.cumsum(np.linspace(0.02, 0.08, 30)) - 0.6
ys = np.linspace(-1.0, 1.0, 25)
zs = np.cumsum(np.linspace(0.05, 0.02, 20)) - 0.5
rect = vtkRectilinearGrid()
rect.SetDimensions(len(xs), len(ys), len(zs))
for setter, values in ((rect.SetXCoordinates, xs), (rect.SetYCoordinates, ys), (rect.SetZCoordinates, zs)):
    setter(numpy_to_vtk(values.astype(np.float64), deep=True))
Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")
values = numpy_to_vtk(field(X, Y, Z).astype(np.float32).ravel(), deep=True)
values.SetName("f")
rect.GetPointData().AddArray(values)
nc, out, psnr, samples = compress("rectilinear", producer(rect, "anydataset_rect.vtr"), "f")
check(samples == rect.GetNumberOfPoints(), "rectilinear: PSNR measured at all %d points (%s)"
      % (rect.GetNumberOfPoints(), samples))
check(psnr is not None and psnr > 33.0, "rectilinear: PSNR at the source points > 33 dB (%s)" % psnr)
decoded = vtk_to_numpy(out.GetPointData().GetArray("f"))
check(np.isfinite(decoded).all(), "rectilinear: no decoded point outside the domain")
b = out.GetBounds()
# vtkResampleToImage keeps its outermost samples a millionth of the extent inside the bounds
check(all(abs(b[i] - rect.GetBounds()[i]) < 1e-5 for i in range(6)), "rectilinear: output covers the input bounds "
      "(%s vs %s)" % (b, rect.GetBounds()))

# 2. A curvilinear structured grid: a half annulus (r in [0.5, 1], angle in [0, pi], z in [0, 1]); points of the
#    bounding box outside the shell decode to NaN, those inside are finite; a cell field.
nr, nt, nz = 12, 40, 10
r, t, zz = np.meshgrid(np.linspace(0.5, 1.0, nr), np.linspace(0.0, math.pi, nt), np.linspace(0.0, 1.0, nz),
                       indexing="ij")
pts = np.stack([r * np.cos(t), r * np.sin(t), zz], axis=-1).transpose(2, 1, 0, 3).reshape(-1, 3)
sg = vtkStructuredGrid()
sg.SetDimensions(nr, nt, nz)
points = vtkPoints()
points.SetData(numpy_to_vtk(pts.astype(np.float64), deep=True))
sg.SetPoints(points)
values = numpy_to_vtk(field(pts[:, 0], pts[:, 1], pts[:, 2]).astype(np.float64), deep=True)
values.SetName("g")
sg.GetPointData().AddArray(values)
nc, out, psnr, samples = compress("structured", producer(sg, "anydataset_annulus.vts"), "g", SamplingDimensions=[48, 24, 12])
check(out.GetDimensions() == (48, 24, 12), "structured: SamplingDimensions sets the image (%s)"
      % (out.GetDimensions(),))
check(psnr is not None and psnr > 31.0, "structured: PSNR at the source points > 31 dB (%s)" % psnr)
decoded = vtk_to_numpy(out.GetPointData().GetArray("g")).reshape(12, 24, 48)
ox, oy, oz = out.GetOrigin()
sx, sy, sz = out.GetSpacing()
gz, gy, gx = np.meshgrid(oz + sz * np.arange(12), oy + sy * np.arange(24), ox + sx * np.arange(48), indexing="ij")
radius = np.hypot(gx, gy)
inner, inside = radius < 0.45, (radius > 0.55) & (radius < 0.95)
check(np.isnan(decoded[inner]).all(), "structured: every image point inside the hole (r < 0.45) is NaN (%d of %d)"
      % (np.isnan(decoded[inner]).sum(), inner.sum()))
check(np.isfinite(decoded[inside]).all(), "structured: every point well inside the shell is finite (%d of %d)"
      % (np.isfinite(decoded[inside]).sum(), inside.sum()))
if os.environ.get("DISPLAY"):
    # The Neural Volume draws nothing in the hole of the annulus (the network is defined there, the source is not),
    # on every render path; constant opacity, so that everything inside the shell is drawn.
    W = H = 160
    view = nvtest.render_view([W, H], background=(0, 0, 0))
    display = Show(nc, view)
    display.SetScalarBarVisibility(view, False)
    otf = GetOpacityTransferFunction("g")
    lo, hi = out.GetFieldData().GetArray("NeuralValueRange").GetRange()
    otf.Points = [lo, 0.6, 0.5, 0.0, hi, 0.6, 0.5, 0.0]
    Render(view)  # the first render resets the camera; the view is set after it
    nvtest.set_camera(view, (0.0, 0.5, 10.0), focal=(0.0, 0.5, 0.5), up=(0.0, 1.0, 0.0), parallel=1, scale=1.05)
    py, px = np.mgrid[0:H, 0:W]
    wx = 1.05 * (2.0 * (px + 0.5) / W - 1.0)
    wy = 0.5 + 1.05 * (2.0 * (py + 0.5) / H - 1.0)  # read_png's rows go bottom up
    rr = np.hypot(wx, wy)
    hole = (rr < 0.42) & (wy > 0.03)
    shell = (rr > 0.6) & (rr < 0.9) & (wy > 0.05)
    for path in ("Decode", "Sample Streaming", "In-Shader"):
        display.RenderPath = path
        pixels = nvtest.read_png(nvtest.shot(view, os.path.join(nvtest.output_dir(), "anydataset_annulus_%s.png"
                                                                % path.split()[0].lower()), [W, H]))
        lit = pixels.max(axis=2) > 8
        check(hole.sum() > 500 and not lit[hole].any(), "structured, %s: nothing drawn in the hole (%d of %d pixels lit)"
              % (path, lit[hole].sum(), hole.sum()))
        check(lit[shell].mean() > 0.95, "structured, %s: the shell is drawn (%.0f%% of its pixels)"
              % (path, 100 * lit[shell].mean()))
    Delete(display)

# 3. A multiblock of two images side by side: ONE network over both (the "two separate networks"), which
#    the Neural Volume renders.
mb = vtkMultiBlockDataSet()
for k in range(2):
    im = vtkImageData()
    im.SetDimensions(20, 20, 20)
    im.SetOrigin(k * 1.0, 0.0, 0.0)
    im.SetSpacing(1.0 / 19.0, 1.0 / 19.0, 1.0 / 19.0)
    Z, Y, X = np.meshgrid(*(np.linspace(0, 1, 20),) * 3, indexing="ij")
    a = numpy_to_vtk(field(X + k, Y, Z).astype(np.float32).ravel(), deep=True)
    a.SetName("h")
    im.GetPointData().AddArray(a)
    mb.SetBlock(k, im)
source = producer(mb, "anydataset_two_images.vtm")
nc, out, psnr, samples = compress("multiblock", source, "h", OutputMode="Network only")
check(out.GetFieldData().GetArray("NeuralNetwork") is not None, "multiblock: one output image with one network")
check(samples == 16000, "multiblock: PSNR at the 16000 points of both blocks (%s)" % samples)
check(psnr is not None and psnr > 33.0, "multiblock: PSNR at the source points > 33 dB (%s)" % psnr)
b = out.GetBounds()
check(abs(b[0]) < 1e-5 and abs(b[1] - 2.0) < 1e-5, "multiblock: the image spans both blocks (x %s..%s)" % b[:2])
if os.environ.get("DISPLAY"):
    view = nvtest.render_view([200, 120], background=(0, 0, 0))
    display = Show(nc, view)
    check(display.Representation == "Neural Volume", "multiblock: shown as a Neural Volume (%s)" % display.Representation)
    view.ResetCamera()
    pixels = nvtest.read_png(nvtest.shot(view, os.path.join(nvtest.output_dir(), "anydataset_multiblock.png"),
                                         [200, 120]))
    lit = float((pixels.max(axis=2) > 20).mean())
    check(lit > 0.25, "multiblock: the Neural Volume draws the network (%.0f%% of the pixels lit)" % (100 * lit))

# 4. Poly data: a planar triangulated field trains (a 2D field); a closed surface in 3D is refused with a clear error.
plane = Plane(XResolution=30, YResolution=30)
calc = Calculator(Input=plane, ResultArrayName="p", Function="sin(3*coordsX)*cos(2*coordsY)")
nc, out, psnr, samples = compress("planar poly data", calc, "p")
check(out.GetDimensions()[2] == 1 and psnr is not None and psnr > 30.0,
      "planar poly data: a flat image, PSNR > 30 dB (%s, %s)" % (out.GetDimensions(), psnr))
sphere = Calculator(Input=Sphere(), ResultArrayName="s", Function="coordsZ")
with nvtest.captured_messages() as messages:
    bad = NeuralCompress(Input=sphere, SelectInputScalars=["POINTS", "s"], **COMMON)
    bad.UpdatePipeline()
out = servermanager.Fetch(bad)
check("has no volume to sample" in messages[0], "closed surface: a clear error (%s)" % messages[0])
check(out.GetNumberOfPoints() == 0 or out.GetFieldData().GetArray("NeuralNetwork") is None,
      "closed surface: no network in the output")

# 5. Real data (skipped when absent): PSNR at the source's own points / cells.
data_dir = os.environ.get("NV_DATA_DIR", "")
if data_dir and os.path.isdir(os.path.join(data_dir, "disk_out_ref")):
    D = data_dir + "/"
    disk = ExodusIIReader(FileName=D + "disk_out_ref/disk_out_ref.ex2")
    disk.PointVariables = ["Temp"]
    nc, out, psnr, samples = compress("disk_out_ref Temp", disk, "Temp")
    check(samples == 8499 and psnr > 27.0, "disk_out_ref: PSNR at its 8499 points > 27 dB (%s, %s)" % (samples, psnr))
    mug = ExodusIIReader(FileName=D + "mug_moose/mug.e")
    mug.PointVariables = ["convected"]
    nc, out, psnr, samples = compress("mug convected t=10", mug, "convected", time=mug.TimestepValues[10])
    check(samples == 3954 and psnr > 25.0, "mug: PSNR at its 3954 points > 25 dB (%s, %s)" % (samples, psnr))
    # A time series of an unstructured grid: each time step is resampled and trained (warm start from the one
    # before), the metrics table has a row per time step, and going back to a time step trains nothing.
    ncm = NeuralCompress(Input=mug, SelectInputScalars=["POINTS", "convected"], WarmStart=1, **COMMON)
    for t in (mug.TimestepValues[5], mug.TimestepValues[10], mug.TimestepValues[5]):
        ncm.UpdatePipeline(t)
    ncm.SMProxy.UpdatePropertyInformation()
    table = servermanager.Fetch(ncm, idx=2)
    rows = table.GetNumberOfRows()
    warm = [table.GetColumnByName("WarmStart").GetValue(r) for r in range(rows)]
    psnrs = [table.GetColumnByName("PSNR").GetValue(r) for r in range(rows)]
    steps = int(ncm.GetPropertyValue("TotalStepsTrained"))
    check(rows == 2 and warm == [0.0, 1.0] and min(psnrs) > 25.0 and steps == 600,
          "mug time series: 2 rows (%d), the second warm-started (%s), PSNR at the points %s, %d steps (600: "
          "going back trained nothing)" % (rows, warm, psnrs, steps))
    enzo = EnzoReader(FileNames=[D + "enzo_amr_moving7/DD0010/moving7_0010.hierarchy"])
    enzo.CellArrayStatus = ["Density"]
    nc, out, psnr, samples = compress("Enzo AMR Density", enzo, "Density", "CELLS")
    check(psnr is not None and psnr > 37.0, "Enzo AMR: PSNR at its visible cells > 37 dB (%s)" % psnr)
    cth = SpyPlotReader(FileName=D + "cth_spyplot_timeseries/spcth_a.0")
    cth.CellArrays = ["Pressure (dynes/cm^2^)"]
    nc, out, psnr, samples = compress("CTH AMR Pressure", cth, "Pressure (dynes/cm^2^)", "CELLS",
                                      time=cth.TimestepValues[-1])
    check(psnr is not None and psnr > 36.0, "CTH AMR: PSNR at its cells > 36 dB (%s)" % psnr)
else:
    log("real data sets not found under NV_DATA_DIR=%r: generated cases only" % data_dir)

nvtest.finish()
