"""Neural Compress on particles (issue 26): a procedural set of 200 000 particles drawn from a Gaussian density
truncated to a ball (r < 0.45 around (0.5, 0.5, 0.5)) with values from an analytic function.
1. The engine's reconstruction (Neural Particle Field: the code Neural Compress trains on) against VTK's own
   vtkSPHInterpolator (cubic spline, Shepard normalisation) and vtkPointInterpolator (Gaussian kernel, normalised
   weights) on a 48^3 grid: the same values and the same empty points; the Density field against vtkSPHInterpolator
   with a mass array (sum m W, absolute units).
2. Training (Probe bank, 300 steps, CPU, Deterministic): the network against the reconstruction at the particles
   (NeuralPSNR), against the analytic function at the particles, and against vtkSPHInterpolator's grid; the decoded
   field is NaN outside the support.
3. The Neural Volume draws it: lit inside the ball, nothing outside the support, on every render path.
4. Bad input: no scalar array, all particles at one point, NaN positions, zero or negative radii, a negative
   ParticleRadius, a cell array: an error naming the cause or the documented treatment (skipped and counted).
Thresholds are the values measured on the CPU engine (2 threads) minus a margin."""
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
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPolyData, vtkUnstructuredGrid  # noqa: E402
from vtkmodules.vtkFiltersCore import vtkProbeFilter  # noqa: E402
from vtkmodules.vtkFiltersPoints import (vtkGaussianKernel, vtkPointInterpolator, vtkSPHCubicKernel,  # noqa: E402
                                         vtkSPHInterpolator)

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
N, RADIUS = 200000, 0.025
# No Sampling: particles always train from the Probe bank (the reconstruction at random points).
COMMON = dict(TrainingSteps=300, BatchSize=16384, Device="CPU", Threads=2, Deterministic=1, Log2TableSize=16)


def analytic(p):
    return np.sin(4.0 * p[:, 0]) * np.cos(3.0 * p[:, 1]) + 0.5 * p[:, 2]


def particles(n, seed=7):
    rng = np.random.default_rng(seed)
    p = rng.normal(0.5, 0.18, (3 * n, 3))
    return p[np.linalg.norm(p - 0.5, axis=1) < 0.45][:n]


def poly_of(p, arrays):
    pd = vtkPolyData()
    pts = vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(p, dtype=np.float64), deep=True))
    pd.SetPoints(pts)
    for name, values in arrays.items():
        a = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        a.SetName(name)
        pd.GetPointData().AddArray(a)
    return pd


def producer(dataset):
    src = PVTrivialProducer()
    src.GetClientSideObject().SetOutput(dataset)
    return src


def fd(data, name):
    a = data.GetFieldData().GetAbstractArray(name)
    return None if a is None else (a.GetVariantValue(0).ToString() if a.IsA("vtkStringArray")
                                   else a.GetVariantValue(0).ToDouble())


def grid_like(image):
    g = vtkImageData()
    g.SetOrigin(image.GetOrigin())
    g.SetSpacing(image.GetSpacing())
    g.SetDimensions(image.GetDimensions())
    return g


def vtk_reference(pd, grid, kernel):
    """VTK's reconstruction of 'f' at the grid's points: (values, valid mask)."""
    if kernel == "cubic":
        k = vtkSPHCubicKernel()
        k.SetSpatialStep(RADIUS / 2.0)  # the cubic spline's cutoff is 2 h = RADIUS
        k.SetDimension(3)
        interp = vtkSPHInterpolator()
        interp.SetShepardNormalization(True)
    else:
        k = vtkGaussianKernel()
        k.SetKernelFootprintToRadius()
        k.SetRadius(RADIUS)
        k.SetSharpness(math.sqrt(4.5))  # exp(-4.5 q^2): sigma = RADIUS / 3
        k.NormalizeWeightsOn()
        interp = vtkPointInterpolator()
    interp.SetKernel(k)
    interp.SetInputData(grid)
    interp.SetSourceData(pd)
    interp.SetNullPointsStrategyToMaskPoints()
    interp.Update()
    out = interp.GetOutput()
    values = vtk_to_numpy(out.GetPointData().GetArray("f")).astype(np.float64)
    valid = vtk_to_numpy(out.GetPointData().GetArray(interp.GetValidPointsMaskArrayName())) != 0
    return values, valid


P = particles(N)
F = analytic(P)
PD = poly_of(P, {"f": F.astype(np.float32)})
SRC = producer(PD)
RANGE = float(F.max() - F.min())

# 1. The reconstruction against VTK's interpolators on a 48^3 grid.
for kernel, label in (("cubic", "Cubic Spline"), ("gaussian", "Gaussian")):
    field = NeuralParticleField(Input=SRC, SelectInputScalars=["POINTS", "f"], ParticleKernel=label,
                                ParticleRadius=RADIUS, SamplingDimensions=[48, 48, 48])
    field.UpdatePipeline()
    ours = servermanager.Fetch(field)
    mine = vtk_to_numpy(ours.GetPointData().GetArray("f")).astype(np.float64)
    ref, valid = vtk_reference(PD, grid_like(ours), kernel)
    both = valid & np.isfinite(mine)
    disagree = int((valid != np.isfinite(mine)).sum())
    diff = np.abs(mine[both] - ref[both]) / RANGE
    err, median = diff.max(), np.median(diff)
    log("reconstruction %s vs VTK: %d of %d points inside, %d differ in emptiness, |diff| max %.2e, median %.2e of "
        "the range" % (label, both.sum(), mine.size, disagree, err, median))
    check(both.sum() > 0.3 * mine.size, "%s: the support covers the ball (%d points)" % (label, both.sum()))
    check(disagree <= 0.0005 * mine.size, "%s: empty where VTK's is (%d of %d points differ)" % (label, disagree,
                                                                                                mine.size))
    # The cubic spline is continuous at the support's edge: within 2e-5 (float32 positions and values). The truncated
    # Gaussian jumps there (to e^-4.5 of its peak), so a particle at the edge that float rounding puts inside for one
    # and outside for the other changes a sum: within 1e-3 (measured 1.5e-4), the median within 2e-6.
    tolerance = 2e-5 if kernel == "cubic" else 1e-3
    check(err < tolerance and median < 2e-6, "%s: the reconstruction matches VTK's within %g of the range (max %.2e, "
          "median %.2e)" % (label, tolerance, err, median))
    Delete(field)

# The density (sum m_i W_i) against vtkSPHInterpolator with a mass array and a density array of ones, interpolating
# the ones: sum (m_j / 1) 1 W_j, in absolute units (both cubic splines integrate to one).
masses = (0.5 + np.random.default_rng(5).random(N)) / N
DENSITY_PD = poly_of(P, {"m": masses, "one": np.ones(N)})
field = NeuralParticleField(Input=producer(DENSITY_PD), SelectInputScalars=["POINTS", "m"], ParticleField="Density",
                            ParticleRadius=RADIUS, SamplingDimensions=[48, 48, 48])
field.UpdatePipeline()
ours = servermanager.Fetch(field)
mine = vtk_to_numpy(ours.GetPointData().GetArray("m")).astype(np.float64)
k = vtkSPHCubicKernel()
k.SetSpatialStep(RADIUS / 2.0)
k.SetDimension(3)
interp = vtkSPHInterpolator()
interp.SetKernel(k)
interp.SetMassArrayName("m")
interp.SetDensityArrayName("one")
interp.SetInputData(grid_like(ours))
interp.SetSourceData(DENSITY_PD)
interp.SetNullPointsStrategyToMaskPoints()
interp.Update()
ref = vtk_to_numpy(interp.GetOutput().GetPointData().GetArray("one")).astype(np.float64)
valid = vtk_to_numpy(interp.GetOutput().GetPointData().GetArray(interp.GetValidPointsMaskArrayName())) != 0
both = valid & np.isfinite(mine)
err = np.abs(mine[both] - ref[both]).max() / ref[both].max()
log("density vs vtkSPHInterpolator (mass / density arrays): max %.3f, max |diff| %.2e of the max, %d differ in "
    "emptiness" % (ref[both].max(), err, int((valid != np.isfinite(mine)).sum())))
check(err < 2e-5 and int((valid != np.isfinite(mine)).sum()) == 0, "density: VTK's sum m W within 2e-5 (%.2e)" % err)
Delete(field)

# 2. Training on the Probe bank; the figures at the particles and against VTK's grid.
with nvtest.captured_messages() as text:
    nc = NeuralCompress(Input=SRC, SelectInputScalars=["POINTS", "f"], ParticleRadius=RADIUS, **COMMON)
    nc.UpdatePipeline()
check("Probe: " in text[0] and "200000 particles, cubic spline kernel, radius 0.025" in text[0],
      "trained from the Probe bank of the particle field (%r)" % text[0][-600:])
out = servermanager.Fetch(nc)
psnr, max_error, samples = fd(out, "NeuralPSNR"), fd(out, "NeuralMaxError"), fd(out, "NeuralSourceSamples")
ratio = fd(out, "NeuralCompressionRatio")
log("trained: PSNR %s dB, max error %s at %s particles, ratio %s (positions + scalar), dims %s"
    % (psnr, max_error, samples, ratio, out.GetDimensions()))
check(samples == N, "the PSNR is measured at all %d particles (%s)" % (N, samples))
check(psnr is not None and psnr > 35.0, "network vs the reconstruction at the particles > 35 dB (%s)" % psnr)
check(max_error is not None and max_error < 0.25, "max error at the particles < 0.25 (%s)" % max_error)
check(ratio is not None and abs(ratio - (N * 28.0) / fd(out, "NeuralModelBytes")) < 1e-3 * ratio,
      "ratio = (positions + scalar bytes) / model bytes (%s)" % ratio)
decoded = vtk_to_numpy(out.GetPointData().GetArray("f")).astype(np.float64)
probe = vtkProbeFilter()
probe.SetInputData(poly_of(P, {}))
probe.SetSourceData(out)
probe.Update()
at = vtk_to_numpy(probe.GetOutput().GetPointData().GetArray("f")).astype(np.float64)
ok = np.isfinite(at)
psnr_analytic = 20 * math.log10(RANGE / math.sqrt(np.mean((at[ok] - F[ok]) ** 2)))
log("network (decoded, trilinear) vs the analytic function at %d particles: %.2f dB, max %.4f"
    % (ok.sum(), psnr_analytic, np.abs(at[ok] - F[ok]).max()))
check(ok.mean() > 0.99, "the decoded field is defined at the particles (%.4f)" % ok.mean())
check(psnr_analytic > 33.0, "network vs the analytic function at the particles > 33 dB (%.2f)" % psnr_analytic)
ref, valid = vtk_reference(PD, grid_like(out), "cubic")
both = valid & np.isfinite(decoded)
psnr_vtk = 20 * math.log10(RANGE / math.sqrt(np.mean((decoded[both] - ref[both]) ** 2)))
log("network vs vtkSPHInterpolator on the %s grid: %.2f dB at %d points; NaN at %d of %d points VTK leaves empty"
    % (out.GetDimensions(), psnr_vtk, both.sum(), np.isnan(decoded[~valid]).sum(), (~valid).sum()))
check(psnr_vtk > 33.0, "network vs vtkSPHInterpolator's grid > 33 dB (%.2f)" % psnr_vtk)
check(np.isnan(decoded[~valid]).mean() > 0.999, "decoded NaN outside the support (%.4f)"
      % np.isnan(decoded[~valid]).mean())

# 3. The Neural Volume draws the particles' field: lit inside the ball, nothing beyond the support (r > 0.45 + R in
#    projection), on every render path; constant opacity so that everything inside is drawn.
if os.environ.get("DISPLAY"):
    W = H = 160
    view = nvtest.render_view([W, H], background=(0, 0, 0))
    display = Show(nc, view)
    display.SetScalarBarVisibility(view, False)
    otf = GetOpacityTransferFunction("f")
    lo, hi = out.GetFieldData().GetArray("NeuralValueRange").GetRange()
    otf.Points = [lo, 0.6, 0.5, 0.0, hi, 0.6, 0.5, 0.0]
    Render(view)
    nvtest.set_camera(view, (0.5, 0.5, 10.0), focal=(0.5, 0.5, 0.5), up=(0.0, 1.0, 0.0), parallel=1, scale=0.6)
    py, px = np.mgrid[0:H, 0:W]
    wx = 0.5 + 0.6 * (2.0 * (px + 0.5) / W - 1.0)
    wy = 0.5 + 0.6 * (2.0 * (py + 0.5) / H - 1.0)
    rr = np.hypot(wx - 0.5, wy - 0.5)
    inner, outer = rr < 0.3, rr > 0.45 + RADIUS + 0.02
    for path in ("Decode", "Sample Streaming", "In-Shader"):
        display.RenderPath = path
        pixels = nvtest.read_png(nvtest.shot(view, os.path.join(
            nvtest.output_dir(), "particles_%s.png" % path.split()[0].lower()), [W, H]))
        lit = pixels.max(axis=2) > 8
        log("render %s: %.1f%% of the inner disc lit, %d of %d pixels beyond the support lit"
            % (path, 100 * lit[inner].mean(), lit[outer].sum(), outer.sum()))
        check(lit[inner].mean() > 0.98, "%s: the ball is drawn (%.1f%%)" % (path, 100 * lit[inner].mean()))
        check(outer.sum() > 2000 and not lit[outer].any(), "%s: nothing drawn beyond the support (%d pixels)"
              % (path, lit[outer].sum()))
    Delete(display)
    Delete(view)
else:
    log("no DISPLAY: the rendering part is skipped")
Delete(nc)


# 4. Bad input: each gives its error (and an empty output) or its documented treatment; none crashes.
def attempt(dataset, scalars=("POINTS", "f"), **extra):
    """Compress `dataset` (small and quick); returns (output, captured messages)."""
    kwargs = dict(COMMON, TrainingSteps=40, BatchSize=4096, Log2TableSize=12)
    kwargs.update(extra)
    with nvtest.captured_messages() as text:
        src = producer(dataset)
        filt = NeuralCompress(Input=src, SelectInputScalars=list(scalars), **kwargs) if scalars else \
            NeuralCompress(Input=src, **kwargs)
        filt.UpdatePipeline()
        result = servermanager.Fetch(filt)
        Delete(filt)
        Delete(src)
    return result, text[0]


small = particles(20000, seed=3)
values = analytic(small).astype(np.float32)
result, text = attempt(poly_of(small, {}), scalars=None)
check("no input array" in text and fd(result, "NeuralPSNR") is None, "no scalar array: an error (%r)" % text[-300:])
result, text = attempt(poly_of(np.tile([[0.2, 0.3, 0.4]], (500, 1)), {"f": np.ones(500, np.float32)}))
check("lie at one point" in text and fd(result, "NeuralPSNR") is None, "all at one point: an error (%r)" % text[-300:])
bad = small.copy()
bad[::10, 1] = np.nan  # 2000 particles with a NaN position: skipped
result, text = attempt(poly_of(bad, {"f": values}))
check(fd(result, "NeuralSourceSamples") == 18000 and "Error" not in text,
      "NaN positions: skipped, the figures at the 18000 others (%s; %r)" % (fd(result, "NeuralSourceSamples"),
                                                                           text[-300:]))
radii = np.full(20000, RADIUS * 1.6)
radii[::4] = 0.0
radii[1::4] = -1.0  # half the radii zero or negative: skipped and counted
result, text = attempt(poly_of(small, {"f": values, "Radius": radii}), ParticleRadiusArray="Radius")
check(fd(result, "NeuralPSNR") is not None and "10000 radii not positive" in text,
      "zero and negative radii: skipped and counted (%r)" % text[-400:])
result, text = attempt(poly_of(small, {"f": values, "Radius": -np.abs(radii)}), ParticleRadiusArray="Radius")
check("none of the 20000 particles" in text and fd(result, "NeuralPSNR") is None,
      "all radii zero or negative: an error (%r)" % text[-300:])
result, text = attempt(poly_of(small, {"f": values}), ParticleRadiusArray="NoSuchArray")
check("no point array 'NoSuchArray'" in text, "a missing radius array: an error (%r)" % text[-300:])
result, text = attempt(poly_of(small, {"f": values}), ParticleRadius=-0.1)
check("radius must be >= 0" in text and fd(result, "NeuralPSNR") is None, "a negative radius: an error (%r)"
      % text[-300:])
# An unstructured grid of vertex cells trains like poly data; a cell array of it is refused.
ug = vtkUnstructuredGrid()
ug.SetPoints(poly_of(small, {}).GetPoints())
ug.Allocate(20000)
for i in range(20000):
    ug.InsertNextCell(1, 1, [i])  # VTK_VERTEX
a = numpy_to_vtk(values, deep=True)
a.SetName("f")
ug.GetPointData().AddArray(a)
c = numpy_to_vtk(np.ones(20000, np.float32), deep=True)
c.SetName("g")
ug.GetCellData().AddArray(c)
result, text = attempt(ug)
check(fd(result, "NeuralSourceSamples") == 20000 and (fd(result, "NeuralPSNR") or 0) > 20.0,
      "an unstructured grid of vertices trains (%s dB)" % fd(result, "NeuralPSNR"))
result, text = attempt(ug, scalars=("CELLS", "g"))
check("is not one" in text and fd(result, "NeuralPSNR") is None, "a cell array of particles: an error (%r)"
      % text[-300:])
nvtest.finish()
