"""Neural Compress on a real particle data set (issue 26): the dark-matter particles of the Enzo cosmology output
moving7 DD0010 (VTK's test data, /work/shared/data/enzo_amr_moving7; SKIP when NV_DATA_DIR lacks it).

ParaView 5.11's "Enzo Particles Reader" (ENZOAMRParticlesReader, vtkAMREnzoParticlesReader) reads the particles
of all 10 grids (9233 in all, positions in [0,1]^3) from the grids' HDF5 file. Its arrays (particle_mass,
particle_velocity_x/y/z, particle_index, particle_type) appear only after its first execution, all unselected (the
reader gathers its metadata in RequestData and then disables every array), so a script updates it once, selects the
arrays and updates it again; in the GUI the arrays show after the first Apply.

1. The reader: 10 blocks of poly data, 9233 distinct particles with their velocities.
2. particle_velocity_x (interpolated, cubic spline, automatic radius): the network against the reconstruction at the
   9233 particles (NeuralPSNR) and the decoded field against the particles' own values.
3. The same with adaptive per-particle radii (2 x the distance to the 16th nearest neighbour, as SPH smoothing
   lengths go: 0.003 in the halo to 0.3 in the voids, a ratio of about 100): the locator's radius classes keep the
   reconstruction quick (the single grid of the largest radius made every query visit most particles).
Thresholds are the values measured on the CPU engine (2 threads) minus a margin."""
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonCore import vtkPoints  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkMultiBlockDataSet, vtkPolyData  # noqa: E402
from vtkmodules.vtkFiltersCore import vtkProbeFilter  # noqa: E402

HIERARCHY = os.path.join(os.environ.get("NV_DATA_DIR", "/work/shared/data"),
                         "enzo_amr_moving7", "DD0010", "moving7_0010.hierarchy")
if not os.path.exists(HIERARCHY):
    nvtest.skip("the Enzo data set is absent (%s)" % HIERARCHY)

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
ARRAYS = ["particle_index", "particle_mass", "particle_type", "particle_velocity_x", "particle_velocity_y",
          "particle_velocity_z"]
# A 2^14 table: these 9233 particles are 253 KiB (float64 positions + float32 velocity).
COMMON = dict(TrainingSteps=300, BatchSize=16384, Device="CPU", Threads=2, Deterministic=1, Log2TableSize=14,
              SelectInputScalars=["POINTS", "particle_velocity_x"])


def fd(data, name):
    return nvtest.field_value(data, name)


# 1. The reader, updated twice: its arrays exist only after its first execution.
reader = ENZOAMRParticlesReader(FileNames=[HIERARCHY])
reader.UpdatePipeline()
reader.ParticleArrayStatus = ARRAYS
reader.UpdatePipeline()
particles = servermanager.Fetch(reader)
blocks = [particles.GetBlock(i) for i in range(particles.GetNumberOfBlocks())]
P = np.concatenate([vtk_to_numpy(b.GetPoints().GetData()) for b in blocks])
VX = np.concatenate([vtk_to_numpy(b.GetPointData().GetArray("particle_velocity_x")) for b in blocks]).astype(float)
ids = np.concatenate([vtk_to_numpy(b.GetPointData().GetArray("particle_index")) for b in blocks])
log("Enzo particles: %d blocks, %d particles (%d distinct indices), box %s - %s, particle_velocity_x %.4f to %.4f"
    % (len(blocks), len(P), len(np.unique(ids)), P.min(0).round(4), P.max(0).round(4), VX.min(), VX.max()))
check(len(blocks) == 10 and len(P) == 9233 and len(np.unique(ids)) == 9233,
      "the reader gives the 9233 distinct particles of the 10 grids (%d in %d blocks)" % (len(P), len(blocks)))
check(P.min() >= 0.0 and P.max() <= 1.0 and np.isfinite(VX).all(), "positions in [0,1]^3 with finite velocities")
RANGE = float(VX.max() - VX.min())


def decoded_at_particles(out, name="particle_velocity_x"):
    """The decoded field (trilinear in the output image) at the particles' positions."""
    pd = vtkPolyData()
    pts = vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(P), deep=True))
    pd.SetPoints(pts)
    probe = vtkProbeFilter()
    probe.SetInputData(pd)
    probe.SetSourceData(out)
    probe.Update()
    return vtk_to_numpy(probe.GetOutput().GetPointData().GetArray(name)).astype(float)


def train(source, label, psnr_floor, particle_floor, **extra):
    with nvtest.captured_messages() as text:
        t0 = time.time()
        nc = NeuralCompress(Input=source, **dict(COMMON, **extra))
        nc.UpdatePipeline()
        wall = time.time() - t0
    out = servermanager.Fetch(nc)
    psnr, max_error, samples = fd(out, "NeuralPSNR"), fd(out, "NeuralMaxError"), fd(out, "NeuralSourceSamples")
    at = decoded_at_particles(out)
    ok = np.isfinite(at)
    rms = math.sqrt(np.mean((at[ok] - VX[ok]) ** 2)) if ok.any() else float("nan")
    psnr_particles = 20 * math.log10(RANGE / rms) if rms > 0 else float("nan")
    description = [line for line in text[0].splitlines() if "particles:" in line]
    log("%s: %.1f s; network vs the reconstruction at %s particles: %s dB, max error %s; decoded field vs the "
        "particles' own values: %.2f dB at %d of %d; ratio %s (positions + scalar); %s"
        % (label, wall, samples, psnr, max_error, psnr_particles, ok.sum(), len(P),
           fd(out, "NeuralCompressionRatio"), description[0].strip()[:400] if description else text[0][-600:]))
    check(samples == 9233, "%s: the figures at all 9233 particles (%s)" % (label, samples))
    check(psnr is not None and psnr > psnr_floor, "%s: network vs reconstruction at the particles > %g dB (%s)"
          % (label, psnr_floor, psnr))
    check(ok.mean() > 0.999, "%s: the decoded field is defined at the particles (%.4f)" % (label, ok.mean()))
    check(psnr_particles > particle_floor, "%s: decoded vs the particles' values > %g dB (%.2f)"
          % (label, particle_floor, psnr_particles))
    Delete(nc)
    return out, description[0] if description else ""


# 2. Automatic constant radius.
train(reader, "automatic radius", 36.0, 25.0)

# 3. Adaptive radii: 2 x the distance to the 16th nearest neighbour (brute force, in chunks).
K = 16
h = np.empty(len(P))
for first in range(0, len(P), 1024):
    d2 = ((P[first:first + 1024, None, :] - P[None, :, :]) ** 2).sum(axis=2)
    h[first:first + 1024] = 2.0 * np.sqrt(np.partition(d2, K, axis=1)[:, K])
log("adaptive radii: %.4f to %.4f (median %.4f)" % (h.min(), h.max(), np.median(h)))
check(h.max() / h.min() > 30.0, "the adaptive radii span a wide range (%.0f x)" % (h.max() / h.min()))
adaptive = vtkMultiBlockDataSet()
adaptive.SetNumberOfBlocks(len(blocks))
offset = 0
for i, b in enumerate(blocks):
    copy = vtkPolyData()
    copy.ShallowCopy(b)
    a = numpy_to_vtk(np.ascontiguousarray(h[offset:offset + b.GetNumberOfPoints()]), deep=True)
    a.SetName("h")
    copy.GetPointData().AddArray(a)
    adaptive.SetBlock(i, copy)
    offset += b.GetNumberOfPoints()
source = PVTrivialProducer()
source.GetClientSideObject().SetOutput(adaptive)
out, description = train(source, "adaptive radii", 28.0, 25.0, ParticleRadiusArray="h")
check("8 radius classes" in description, "adaptive radii: the locator files them in 8 radius classes (%r)"
      % description[:300])
nvtest.finish()
