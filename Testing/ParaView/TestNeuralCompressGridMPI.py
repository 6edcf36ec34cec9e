"""Neural Compress of an unstructured grid under MPI without a gather (issue 23): `mpiexec -n 2` and `-n 4 pvbatch`.

Wavelet [0,40]^3 -> Tetrahedralize (320000 tetrahedra) -> RedistributeDataSet (ParaView 5.11's default: a k-d
split, each cell assigned to one region) -> Neural Compress at SamplingDimensions 38^3 (a lattice whose planes do
not fall on the k-d cut, so each rank's region needs samples of its neighbour's cells). Every rank resamples its own
piece onto its region of the lattice, trains its own network, draws it clipped to its region; ParaView composites.
The same for a domain that is not a box (the Wavelet clipped by a sphere: mixed cells, NaN outside) and for the
grid redistributed by D3 with a layer of ghost cells (left out of the ranks' own samples and regions).
Rank 0 first runs the same pipelines without RedistributeDataSet in a serial pvbatch (this script with
--serial-reference <folder>, a subprocess) and checks:
- no gather: each rank's network was trained from its own piece (NeuralPieceSourceSamples is the rank's
  RedistributeDataSet piece's point count, less than the whole grid's) and every rank outputs its own network and
  region (the regions partition the lattice exactly);
- the global figures (NeuralPSNR, NeuralMaxError, NeuralModelBytes, NeuralNetworks) are the same on both ranks and
  NeuralPSNR is numpy's over the decoded regions against the serial resampling of the grid (within 0.05 dB); the
  decoded regions are NaN (the domain mask) exactly where the serial resampling is outside the cells;
- the composited picture against the serial one >= 35 dB, and along the cut (seen edge-on) the pixel error no worse
  than 1.5x the rest.
"""
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

SERIAL = "--serial-reference" in sys.argv
WHOLE = [0, 40, 0, 40, 0, 40]
CENTRE = 20.0
LATTICE = [38, 38, 38]
SETTINGS = dict(SelectInputScalars=["POINTS", "RTData"], Device="CPU", Seed=7, Deterministic=1, TrainingSteps=300,
                BatchSize=16384, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2",
                Log2TableSize=14, Threads=1, PSNRInterval=0, TrainInBackground=0, OutputMode="Decoded, float32",
                SamplingDimensions=LATTICE)
PICTURE_DB = 35.0
GLOBAL_PSNR_DB = 0.05
BAND_RATIO = 1.5
BAND_PIXELS = 4
SIZE = [300, 300]
EDGE_SCALE = 24.0  # parallel scale of the edge-on view: 300 pixels show 48 units
BACKGROUND = [0.32, 0.34, 0.43]

nvtest.load_plugin(globals(), scripted=False)
out_dir = nvtest.output_dir()


def grid():
    return Tetrahedralize(Input=Wavelet(WholeExtent=WHOLE))


def ball():
    """A domain that is not a box: the Wavelet's cells inside a sphere (clipped exactly), mixed cell types."""
    clip = Clip(Input=Wavelet(WholeExtent=WHOLE), ClipType="Sphere", Crinkleclip=0, Invert=1)
    clip.ClipType.Center = [CENTRE, CENTRE, CENTRE]
    clip.ClipType.Radius = 18.0
    return clip


def redistribute(source):
    return RedistributeDataSet(Input=source)


def d3_with_ghosts(source):
    """D3 (ParaView's older redistribution) with a layer of ghost cells on every piece."""
    return D3(Input=source, MinimumNumberOfGhostLevels=1)


# name, source, redistribution, the serial reference's name
CASES = (("grid", grid, redistribute), ("ball", ball, redistribute), ("grid-d3", grid, d3_with_ghosts))
SERIAL_CASES = (("grid", grid), ("ball", ball))


def own_points(piece):
    """Points of a piece that are not ghosts."""
    ghosts = piece.GetPointData().GetArray("vtkGhostType")
    if ghosts is None:
        return piece.GetNumberOfPoints()
    return int(np.sum(vtk_to_numpy(ghosts) == 0))


def render(nc, path, edge=False):
    """The Neural Volume picture: an oblique camera, or one looking down z with the cut planes x = const edge-on."""
    view = nvtest.render_view(SIZE, BACKGROUND)
    display = Show(nc, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "RTData"))
    display.SetScalarBarVisibility(view, False)
    values = nvtest.wavelet_values(WHOLE)
    for tf in (GetColorTransferFunction("RTData"), GetOpacityTransferFunction("RTData")):
        tf.RescaleTransferFunction(values.min(), values.max())
    if edge:
        nvtest.set_camera(view, [CENTRE, CENTRE, CENTRE + 300.0], focal=(CENTRE, CENTRE, CENTRE), up=(0.0, 1.0, 0.0),
                          parallel=1, scale=EDGE_SCALE)
    else:
        nvtest.set_camera(view, [CENTRE + 110.0, CENTRE - 80.0, CENTRE + 150.0], focal=(CENTRE, CENTRE, CENTRE))
    Render(view)
    nvtest.shot(view, path, SIZE)
    Delete(display)
    Delete(view)


def serial_reference(folder):
    result = {}
    for name, make in SERIAL_CASES:
        source = make()
        nc = NeuralCompress(Input=source, **SETTINGS)
        nc.UpdatePipeline()
        data = servermanager.Fetch(nc)
        resampled = ResampleToImage(Input=source, SamplingDimensions=LATTICE, UseInputBounds=1)
        image = servermanager.Fetch(resampled)
        values = vtk_to_numpy(image.GetPointData().GetArray("RTData")).astype(np.float64)
        valid = vtk_to_numpy(image.GetPointData().GetArray("vtkValidPointMask")) != 0
        values[~valid] = np.nan
        np.save(os.path.join(folder, name + ".npy"), values.reshape(LATTICE[2], LATTICE[1], LATTICE[0]))
        result[name] = dict(psnr=nvtest.field_value(data, "NeuralPSNR"),
                            resampled_psnr=nvtest.field_value(data, "NeuralResampledPSNR"),
                            points=servermanager.Fetch(source).GetNumberOfPoints())
        if name == "grid":
            nc.OutputMode = "Network only"
            nc.UpdatePipeline()
            render(nc, os.path.join(folder, "serial.png"))
            render(nc, os.path.join(folder, "serial-edge.png"), edge=True)
    with open(os.path.join(folder, "serial.json"), "w") as f:
        json.dump(result, f)
    nvtest.log("serial reference: %s" % result)


def check_regions_and_figures(nc, redistributed, ranks, name, reference):
    """Each rank's own piece, region and network; the global figures against numpy. Returns the regions' extents."""
    check, log = nvtest.check, nvtest.log
    log("--- %s" % name)
    original = np.load(os.path.join(out_dir, name.split("-")[0] + ".npy"))
    whole = [0, LATTICE[0] - 1, 0, LATTICE[1] - 1, 0, LATTICE[2] - 1]
    pieces = []
    for r in range(ranks):
        local = servermanager.Fetch(redistributed, r)
        piece = servermanager.Fetch(nc, r)
        pieces.append(piece)
        own = nvtest.field_value(piece, "NeuralPieceSourceSamples")
        log("rank %d: redistributed piece %d points (%d not ghosts), %d cells; trained from %s source samples"
            % (r, local.GetNumberOfPoints(), own_points(local), local.GetNumberOfCells(), own))
        check(own == own_points(local) and own < reference["points"],
              "rank %d trained from its own piece only (%s samples; its piece %d points, the grid %d)"
              % (r, own, own_points(local), reference["points"]))
    decoded, extents, figures = nvtest.assemble_pieces(pieces, "RTData", whole, original.shape)
    psnr, max_error, model_bytes, networks = figures
    check(networks == ranks, "NeuralNetworks %s == %d ranks" % (networks, ranks))
    nvtest.check_global_figures(decoded, original, psnr, max_error, GLOBAL_PSNR_DB, "the serial resampling",
                                max_error_scale=lambda numpy_max: numpy_max)
    log("model bytes %d; serial: PSNR %.3f dB at the source, %.3f dB on the lattice"
        % (model_bytes, reference["psnr"], reference["resampled_psnr"]))
    check(psnr >= reference["resampled_psnr"] - 1.0, "per-rank networks no worse than 1 dB below the serial one on "
          "the lattice")
    info = nc.GetDataInformation()
    check(list(info.GetExtent()) == whole, "data information: the whole lattice %s" % str(info.GetExtent()))
    return extents


def check_pictures(extents):
    check, log = nvtest.check, nvtest.log
    nvtest.compare_images(os.path.join(out_dir, "mpi.png"), os.path.join(out_dir, "serial.png"), PICTURE_DB,
                          "%d-rank picture vs serial" % len(extents))
    nvtest.compare_images(os.path.join(out_dir, "mpi-edge.png"), os.path.join(out_dir, "serial-edge.png"),
                          PICTURE_DB, "%d-rank edge-on picture vs serial" % len(extents))
    mpi = nvtest.read_png(os.path.join(out_dir, "mpi-edge.png"))
    serial = nvtest.read_png(os.path.join(out_dir, "serial-edge.png"))
    covered = np.abs(serial - np.array(BACKGROUND) * 255.0).max(axis=2) > 8.0
    error = np.abs(mpi - serial).mean(axis=2)
    band = np.zeros(covered.shape, dtype=bool)
    spacing = (WHOLE[1] - WHOLE[0]) / float(LATTICE[0] - 1)
    pixels_per_unit = SIZE[1] / (2.0 * EDGE_SCALE)
    for cut in sorted({e[1] for e in extents if e[1] < LATTICE[0] - 1}):
        column = int(round(SIZE[0] / 2.0 + (cut * spacing - CENTRE) * pixels_per_unit))
        band[:, max(0, column - BAND_PIXELS):column + BAND_PIXELS + 1] = True
        log("cut x = %.3f at column %d" % (cut * spacing, column))
    for cut in sorted({e[3] for e in extents if e[3] < LATTICE[1] - 1}):
        row = int(round(SIZE[1] / 2.0 - (cut * spacing - CENTRE) * pixels_per_unit))
        band[max(0, row - BAND_PIXELS):row + BAND_PIXELS + 1, :] = True
        log("cut y = %.3f at row %d" % (cut * spacing, row))
    band &= covered
    rest = covered & ~band
    if not check(band.sum() > 100 and rest.sum() > 1000, "the edge-on picture shows the cut (%d band, %d other "
                 "covered pixels)" % (band.sum(), rest.sum())):
        return
    ratio = float(error[band].mean() / max(error[rest].mean(), 1e-9))
    log("cut band: mean error %.3f, rest %.3f (ratio %.2f)" % (error[band].mean(), error[rest].mean(), ratio))
    check(ratio <= BAND_RATIO, "the cut is seamless: band error %.2fx the rest (<= %.1f)" % (ratio, BAND_RATIO))


def mpi_run():
    global out_dir
    check, log = nvtest.check, nvtest.log
    ranks, out_dir, reference = nvtest.mpi_test_start(__file__, out_dir, "GridMPI")
    if reference is None:
        return
    for name, make, spread in CASES:
        redistributed = spread(make())
        nc = NeuralCompress(Input=redistributed, **SETTINGS)
        started = time.time()
        with nvtest.captured_messages() as messages:
            nc.UpdatePipeline()
        log("%s, %d ranks: UpdatePipeline %.1f s" % (name, ranks, time.time() - started))
        check("ERROR" not in messages[0], "no error: %r" % messages[0][-400:])
        extents = check_regions_and_figures(nc, redistributed, ranks, name, reference[name.split("-")[0]])
        if name == "grid":
            nc.OutputMode = "Network only"
            nc.UpdatePipeline()
            render(nc, os.path.join(out_dir, "mpi.png"))
            render(nc, os.path.join(out_dir, "mpi-edge.png"), edge=True)
            check_pictures(extents)
        Delete(nc)


if SERIAL:
    serial_reference(sys.argv[sys.argv.index("--serial-reference") + 1])
else:
    mpi_run()
nvtest.finish()
