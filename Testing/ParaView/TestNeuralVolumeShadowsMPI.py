"""Shadows and path tracing across pieces under MPI (issue 23): `mpiexec -n 2` and `-n 4 pvbatch`.

Every rank trains a network of its own piece of a Wavelet [-32,31]^3 (plus ghost layers) and draws its piece; the light
of Ray Marching + Shadows and of Path Tracing + NEE must still cross the other ranks' pieces (through the coarse grid
of the whole field that Neural Compress gives every rank: field data NeuralSurroundings), so that the composited
picture is the serial one without a brightness step at the piece boundaries. Rank 0 first runs the same pipeline in a
serial pvbatch (this script with --serial-reference <folder>) and checks, for both modes:
- every rank's output carries the surroundings grid, the same on every rank;
- the composited picture against the serial one >= PICTURE_DB (path tracing on 4x4-pixel means: the ranks' paths and
  the serial ones differ where their networks do, so their noise differs);
- with the boundary planes edge-on and the light across them, the pixels along the piece boundaries no worse than
  BAND_RATIO x the mean error of the rest;
- the ranks' networks saved as one .nvol and opened by as many ranks: the reader gives every rank the same grid, and
  its shadowed edge-on picture is the filter's (>= SAME_NETWORK_DB).
With --device CUDA (label gpu-paraview, Testing/Gpu/run_paraview_gpu_mpi.sh; SKIP without a usable GPU) every network
trains and renders on the GPU, the serial reference too.
"""
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
import paraview.simple  # noqa: E402
from paraview import servermanager  # noqa: E402

SERIAL = "--serial-reference" in sys.argv
DEVICE = sys.argv[sys.argv.index("--device") + 1] if "--device" in sys.argv else "CPU"
WHOLE = [-32, 31, -32, 31, -32, 31]  # the Wavelet's peak at the centre, where the pieces meet
CENTRE = -0.5
SETTINGS = dict(SelectInputScalars=["POINTS", "RTData"], Device=DEVICE, Seed=7, Deterministic=1, TrainingSteps=200,
                BatchSize=8192, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2",
                Log2TableSize=14, Threads=1, PSNRInterval=0, TrainInBackground=0, OutputMode="Network only")
# (shading mode, its tag, paths per render, paths accumulated, block of the comparison)
MODES = [("Ray Marching + Shadows", "shadows", 1, 1, 1),
         ("Path Tracing + Next-Event Estimation", "ptnee", 32, 256, 4)]
LIGHT = [0.45, 0.3, 0.85]  # towards the light: across the planes z = const (and y = const) of the pieces
PICTURE_DB = 35.0
SAME_NETWORK_DB = 45.0
BAND_RATIO = 1.5
BAND_PIXELS = 4
SIZE = [160, 160]
BACKGROUND = [0.32, 0.34, 0.43]

nvtest.load_plugin(globals(), scripted=False)
paraview.simple._DisableFirstRenderCameraReset()
out_dir = nvtest.output_dir()


def render(nc, mode, path, edge):
    """The Neural Volume picture in `mode`: an oblique camera, or one with the planes y, z = const edge-on."""
    name, _, spp, target, _ = mode
    view = nvtest.render_view(SIZE, BACKGROUND)
    values = nvtest.wavelet_values(WHOLE)
    display = nvtest.show_styled(nc, view, "RTData", values.min(), values.max(), 0.5)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "RTData"))
    display.SetScalarBarVisibility(view, False)
    display.RenderPath = "Decode"
    display.ShadingMode = name
    display.SamplesPerPixel = spp
    display.TargetSamples = target
    display.Denoise = 0
    display.FollowViewLight = 0
    display.LightDirection = LIGHT
    if edge:
        nvtest.set_camera(view, [CENTRE + 160.0, CENTRE, CENTRE], focal=(CENTRE, CENTRE, CENTRE))
    else:
        nvtest.set_camera(view, [CENTRE + 120.0, CENTRE - 90.0, CENTRE + 110.0], focal=(CENTRE, CENTRE, CENTRE))
    started = time.time()
    Render(view)
    nvtest.shot(view, path, SIZE)
    nvtest.log("%s%s: %.1f s" % (name, " (edge-on)" if edge else "", time.time() - started))
    Delete(display)
    Delete(view)


def pictures(nc, folder, tag):
    for mode in MODES:
        render(nc, mode, os.path.join(folder, "%s-%s.png" % (tag, mode[1])), edge=False)
        render(nc, mode, os.path.join(folder, "%s-%s-edge.png" % (tag, mode[1])), edge=True)


def serial_reference(folder):
    wavelet = Wavelet(WholeExtent=WHOLE)
    nc = NeuralCompress(Input=wavelet, **SETTINGS)
    nc.UpdatePipeline()
    data = servermanager.Fetch(nc)
    nvtest.check(data.GetFieldData().GetArray("NeuralSurroundings") is None, "a serial run has no surroundings grid")
    pictures(nc, folder, "serial")
    with open(os.path.join(folder, "serial.json"), "w") as f:
        json.dump(dict(psnr=nvtest.field_value(data, "NeuralPSNR")), f)


def check_surroundings(nc, ranks):
    """Every rank's output carries the coarse grid of the whole field, the same on every rank, with values."""
    check = nvtest.check
    grids = []
    for r in range(ranks):
        fd = servermanager.Fetch(nc, r).GetFieldData()
        values, dims = fd.GetArray("NeuralSurroundings"), fd.GetArray("NeuralSurroundingsDimensions")
        bounds = fd.GetArray("NeuralSurroundingsBounds")
        if not check(values is not None and dims is not None and bounds is not None,
                     "rank %d's output has the surroundings grid" % r):
            return []
        grid = np.array([values.GetValue(i) for i in range(values.GetNumberOfTuples())], dtype=np.float64)
        shape = [int(dims.GetValue(a)) for a in range(3)]
        box = [bounds.GetValue(k) for k in range(6)]
        grids.append((grid, shape, box))
    grid, shape, box = grids[0]
    finite = np.isfinite(grid)
    nvtest.log("surroundings grid %s over %s: %d values, %d without a value, range %.2f..%.2f"
               % (shape, box, grid.size, int((~finite).sum()), grid[finite].min(), grid[finite].max()))
    check(grid.size == shape[0] * shape[1] * shape[2] and finite.all(), "the grid covers the whole field (every "
          "lattice point decoded by the rank that owns it)")
    check(box == [float(v) for v in WHOLE], "the grid spans the whole field's bounds %s" % box)
    check(all(g[1] == shape and g[2] == box and np.array_equal(g[0], grid) for g in grids),
          "every rank has the same grid")
    values = nvtest.wavelet_values(WHOLE)
    check(grid[finite].min() >= values.min() - 0.1 * np.ptp(values) and
          grid[finite].max() <= values.max() + 0.1 * np.ptp(values), "its values are the field's")
    return grids


def check_mode(mode, extents, folder, tag):
    """The composited pictures against the serial ones, and the boundary band against the rest (edge-on)."""
    check, log = nvtest.check, nvtest.log
    name, short, _, _, block = mode
    nvtest.compare_images(os.path.join(folder, "%s-%s.png" % (tag, short)),
                          os.path.join(folder, "serial-%s.png" % short), PICTURE_DB,
                          "%s: %d-rank picture vs serial" % (name, len(extents)), block)
    edge, serial_edge = (os.path.join(folder, "%s-%s-edge.png" % (t, short)) for t in (tag, "serial"))
    nvtest.compare_images(edge, serial_edge, PICTURE_DB, "%s: %d-rank edge-on picture vs serial"
                          % (name, len(extents)), block)
    mpi, serial = nvtest.read_png(edge), nvtest.read_png(serial_edge)
    covered = np.abs(serial - np.array(BACKGROUND) * 255.0).max(axis=2) > 8.0
    band = nvtest.band_mask(extents, serial.shape, WHOLE, BAND_PIXELS)
    if block > 1:
        mpi, serial = nvtest.block_means(mpi, block), nvtest.block_means(serial, block)
        covered = nvtest.block_means(covered[:, :, None].astype(float), block)[:, :, 0] > 0.5
        band = nvtest.block_means(band[:, :, None].astype(float), block)[:, :, 0] > 0.0
    error = np.abs(mpi - serial).mean(axis=2)
    band &= covered
    rest = covered & ~band
    if not check(band.sum() > 100 // block ** 2 and rest.sum() > 1000 // block ** 2,
                 "%s: the edge-on picture shows the boundaries (%d band, %d other covered pixels)"
                 % (name, band.sum(), rest.sum())):
        return
    ratio = float(error[band].mean() / max(error[rest].mean(), 1e-9))
    log("%s: boundary band mean error %.3f, rest %.3f (ratio %.2f)"
        % (name, error[band].mean(), error[rest].mean(), ratio))
    check(ratio <= BAND_RATIO, "%s: no brightness step at the piece boundaries: band error %.2fx the rest (<= %.1f)"
          % (name, ratio, BAND_RATIO))


def check_nvol(nc, ranks, folder, grids):
    """The .nvol of the ranks' networks opened under MPI: the same surroundings grid, the same shadowed picture."""
    path = os.path.join(folder, "shadows.nvol")
    if os.path.exists(path):
        os.remove(path)
    SaveData(path, proxy=nc)
    opened = NeuralVolumeReader(FileName=path)
    with nvtest.captured_messages() as messages:
        opened.UpdatePipeline()
    nvtest.check("ERROR" not in messages[0] and "surroundings" not in messages[0],
                 ".nvol opened under MPI without an error or a surroundings warning: %r" % messages[0][-300:])
    back = check_surroundings(opened, ranks)
    nvtest.check(bool(back) and bool(grids) and np.array_equal(back[0][0], grids[0][0]) and back[0][1] == grids[0][1],
                 "the .nvol's pieces carry the filter's surroundings grid")
    mode = MODES[0]
    picture = os.path.join(folder, "nvol-%s-edge.png" % mode[1])
    render(opened, mode, picture, edge=True)
    nvtest.compare_images(picture, os.path.join(folder, "mpi%d-%s-edge.png" % (ranks, mode[1])), SAME_NETWORK_DB,
                          "%s: the .nvol's edge-on picture vs the filter's" % mode[0])
    Delete(opened)


def mpi_run():
    check, log = nvtest.check, nvtest.log
    wavelet = Wavelet(WholeExtent=WHOLE)
    nc = NeuralCompress(Input=wavelet, **SETTINGS)
    if DEVICE == "CUDA":
        nc.UpdatePropertyInformation()
        if not nc.GetPropertyValue("GPUUsable"):
            nvtest.skip("no usable GPU on rank 0")
    ranks, folder, reference = nvtest.mpi_test_start(__file__, out_dir, "ShadowsMPI%s" % DEVICE,
                                                     ("--device", DEVICE))
    if reference is None:
        return
    started = time.time()
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    log("%d ranks: UpdatePipeline %.1f s" % (ranks, time.time() - started))
    check("ERROR" not in messages[0] and "surroundings" not in messages[0], "no error, no surroundings warning: %r"
          % messages[0][-400:])
    extents = [servermanager.Fetch(nc, r).GetExtent() for r in range(ranks)]
    grids = check_surroundings(nc, ranks)
    tag = "mpi%d" % ranks
    pictures(nc, folder, tag)
    for mode in MODES:
        check_mode(mode, extents, folder, tag)
    check_nvol(nc, ranks, folder, grids)


if SERIAL:
    serial_reference(sys.argv[sys.argv.index("--serial-reference") + 1])
else:
    mpi_run()
nvtest.finish()
