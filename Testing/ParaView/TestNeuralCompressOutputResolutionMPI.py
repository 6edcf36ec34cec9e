"""Neural Compress's OutputResolution under MPI (issue 23): `mpiexec -n 2` and `-n 4 pvbatch`, one network per rank.

A decoded output resampled by OutputResolution is one lattice over the whole extent, of which every rank outputs its
part (its own samples, points plus the next layer so that neighbouring pieces share one, as ParaView's pieces of an
image do). Rank 0 first runs the same pipelines in a serial pvbatch (this script with --serial-reference <folder>) and
checks, for an image's point array (finer than the source on x, coarser on z), its cell array, and an unstructured
grid (tetrahedra, RedistributeDataSet under MPI) that every rank resamples on its part of one lattice:
- every rank's piece has the serial output's origin and spacing and lies within its whole extent, which the data
  information reports;
- the pieces cover the whole lattice: every point, and every cell exactly once (no gap, no cell drawn twice);
- the assembled decoded field against the serial one >= 35 dB (over the source's value range), and where two
  pieces share a point layer both pieces' values are no further from the serial ones than 2x the mean of all samples
  (seamless: neither decodes the shared layer outside what its network learnt);
- a .nvol saved by the ranks and opened by as many, decoded, gives each rank its piece's samples value for value.
"""
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

SERIAL = "--serial-reference" in sys.argv
WHOLE = [0, 63, 0, 63, 0, 63]
SETTINGS = dict(Device="CPU", Seed=7, Deterministic=1, TrainingSteps=200, BatchSize=16384, Levels=8,
                FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2", Log2TableSize=14, Threads=1,
                PSNRInterval=0, TrainInBackground=0, OutputMode="Decoded, float32")
# (name, association, OutputResolution): points finer on x and coarser on z; cells likewise; a grid's lattice of
# 38^3 decoded finer on x, coarser on y.
CASES = [("points", "POINTS", [97, 80, 41]), ("cells", "CELLS", [50, 37, 29]), ("grid", "POINTS", [53, 29, 44])]
GRID_WHOLE = [0, 40, 0, 40, 0, 40]
GRID_LATTICE = [38, 38, 38]
AGREEMENT_DB = 35.0
SHARED_LAYER_RATIO = 2.0
# Fetch moves a piece through VTK's legacy writer, whose ASCII header keeps about 6 significant digits of the spacing
# and of the first point's position (from which the origin is recovered).
SPACING_RTOL = 1e-5
ORIGIN_ATOL = 1e-3

nvtest.load_plugin(globals(), scripted=False)
out_dir = nvtest.output_dir()


def compress(name, association, resolution):
    if name == "grid":
        source = Tetrahedralize(Input=Wavelet(WholeExtent=GRID_WHOLE))
        if not SERIAL:
            source = RedistributeDataSet(Input=source)
        return NeuralCompress(Input=source, SelectInputScalars=[association, "RTData"], OutputResolution=resolution,
                              SamplingDimensions=GRID_LATTICE, **SETTINGS)
    wavelet = Wavelet(WholeExtent=WHOLE)
    source = PointDatatoCellData(Input=wavelet) if association == "CELLS" else wavelet
    return NeuralCompress(Input=source, SelectInputScalars=[association, "RTData"], OutputResolution=resolution,
                          **SETTINGS)


def arrays_of(data, association):
    attributes = data.GetCellData() if association == "CELLS" else data.GetPointData()
    return attributes.GetArray("RTData")


def serial_reference(folder):
    result = {}
    for name, association, resolution in CASES:
        nc = compress(name, association, resolution)
        nc.UpdatePipeline()
        data = servermanager.Fetch(nc)
        values = vtk_to_numpy(arrays_of(data, association)).astype(np.float64)
        np.save(os.path.join(folder, "serial_%s.npy" % name), values)
        result[name] = dict(extent=list(data.GetExtent()), origin=list(data.GetOrigin()),
                            spacing=list(data.GetSpacing()), psnr=nvtest.field_value(data, "NeuralPSNR"))
    with open(os.path.join(folder, "serial.json"), "w") as f:
        json.dump(result, f)
    nvtest.log("serial reference: %s" % result)


def sample_shape(extent, association):
    """(z, y, x) counts of the samples of an image of point extent `extent`."""
    cells = 1 if association == "CELLS" else 0
    return tuple(max(extent[2 * a + 1] - extent[2 * a] + 1 - cells, 1) for a in (2, 1, 0))


def check_piece_frames(pieces, serial, name):
    check = nvtest.check
    whole = serial["extent"]
    for rank, piece in enumerate(pieces):
        extent = list(piece.GetExtent())
        check(np.allclose(piece.GetOrigin(), serial["origin"], rtol=0, atol=ORIGIN_ATOL) and
              np.allclose(piece.GetSpacing(), serial["spacing"], rtol=SPACING_RTOL, atol=0),
              "%s: rank %d's origin %s and spacing %s are the whole output's (%s, %s)"
              % (name, rank, list(piece.GetOrigin()), list(piece.GetSpacing()), serial["origin"], serial["spacing"]))
        check(all(whole[2 * a] <= extent[2 * a] <= extent[2 * a + 1] <= whole[2 * a + 1] for a in range(3)),
              "%s: rank %d's extent %s lies within the whole %s" % (name, rank, extent, whole))


def assemble(pieces, serial, association, name, expected):
    """The pieces' samples placed into the whole lattice; checks the coverage; returns (field, the differences from
    `expected` of every piece's value at the samples two pieces share)."""
    check = nvtest.check
    whole = serial["extent"]
    shape = sample_shape(whole, association)
    field = np.full(shape, np.nan)
    seen = np.zeros(shape, dtype=np.int32)
    shared = []
    for piece in pieces:
        extent = list(piece.GetExtent())
        values = vtk_to_numpy(arrays_of(piece, association)).astype(np.float64).reshape(sample_shape(extent,
                                                                                                     association))
        where = tuple(slice(extent[2 * a] - whole[2 * a], extent[2 * a] - whole[2 * a] + values.shape[2 - a])
                      for a in (2, 1, 0))
        again = seen[where] > 0
        if again.any():
            for mine in (field[where][again], values[again]):
                difference = np.abs(mine - expected[where][again])
                shared.append(difference[~np.isnan(difference)])
        field[where] = values
        seen[where] += 1
    if association == "CELLS":
        check(np.all(seen == 1), "%s: the pieces hold every cell of the whole lattice exactly once (missing %d, "
              "twice or more %d)" % (name, int(np.sum(seen == 0)), int(np.sum(seen > 1))))
    else:
        check(np.all(seen >= 1), "%s: the pieces hold every point of the whole lattice (%d missing)"
              % (name, int(np.sum(seen == 0))))
        # Every cell of the lattice within one piece: neighbouring pieces share a point layer.
        missing = 0
        for a in range(3):
            starts = {p.GetExtent()[2 * a] for p in pieces}
            ends = {p.GetExtent()[2 * a + 1] for p in pieces if p.GetExtent()[2 * a + 1] < whole[2 * a + 1]}
            missing += len(ends - starts)
        check(missing == 0, "%s: neighbouring pieces share their boundary point layer (%d boundaries without)"
              % (name, missing))
    return field, np.concatenate(shared) if shared else np.zeros(0)


def check_case(nc, ranks, name, association, folder, reference):
    check, log = nvtest.check, nvtest.log
    serial = reference[name]
    info = nc.GetDataInformation()
    check(list(info.GetExtent()) == serial["extent"], "%s: the data information's whole extent %s is the serial "
          "output's %s" % (name, list(info.GetExtent()), serial["extent"]))
    pieces = [servermanager.Fetch(nc, r) for r in range(ranks)]
    for rank, piece in enumerate(pieces):
        log("%s: rank %d extent %s" % (name, rank, list(piece.GetExtent())))
    check_piece_frames(pieces, serial, name)
    expected = np.load(os.path.join(folder, "serial_%s.npy" % name)).reshape(sample_shape(serial["extent"],
                                                                                         association))
    field, shared = assemble(pieces, serial, association, name, expected)
    values = nvtest.wavelet_values(GRID_WHOLE if name == "grid" else WHOLE)
    span = values.max() - values.min()
    valid = ~np.isnan(field) & ~np.isnan(expected)
    same_nan = bool(np.array_equal(np.isnan(field), np.isnan(expected)))
    mse = float(np.mean((field[valid] - expected[valid]) ** 2)) if valid.any() else math.inf
    db = 10.0 * math.log10(span ** 2 / mse) if mse > 0 else math.inf
    log("%s: %d ranks against serial %.2f dB (%d samples NaN, outside the domain)"
        % (name, ranks, db, int(np.isnan(field).sum())))
    check(same_nan and db >= AGREEMENT_DB, "%s: the assembled decoded field against the serial one %.2f dB >= %.0f, "
          "NaN where the serial one is (%s)" % (name, db, AGREEMENT_DB, same_nan))
    if association == "POINTS":
        mean = float(np.abs(field[valid] - expected[valid]).mean())
        ratio = float(shared.mean()) / max(mean, 1e-12) if shared.size else math.inf
        log("%s: %d values at shared samples, mean difference from serial %.3f, all samples %.3f (ratio %.2f)"
            % (name, shared.size, float(shared.mean()) if shared.size else math.nan, mean, ratio))
        check(ratio <= SHARED_LAYER_RATIO, "%s: the shared layers decode as well as the rest (%.2fx <= %.1f)"
              % (name, ratio, SHARED_LAYER_RATIO))
    return pieces


def check_nvol(nc, ranks, pieces, folder):
    """Save Data of the resampled run, opened back decoded by as many ranks: each its piece's samples."""
    path = os.path.join(folder, "resampled.nvol")
    if os.path.exists(path):
        os.remove(path)
    SaveData(path, proxy=nc)
    opened = NeuralVolumeReader(FileName=path, OutputMode="Decoded, float32")
    with nvtest.captured_messages() as messages:
        opened.UpdatePipeline()
    nvtest.check("ERROR" not in messages[0], ".nvol opened decoded without an error: %r" % messages[0][-300:])
    for r in range(ranks):
        back = servermanager.Fetch(opened, r)
        mine = vtk_to_numpy(pieces[r].GetPointData().GetArray("RTData"))
        array = back.GetPointData().GetArray("RTData")
        theirs = vtk_to_numpy(array) if array is not None else np.zeros(0)
        same_frame = list(back.GetExtent()) == list(pieces[r].GetExtent()) and np.allclose(
            back.GetOrigin(), pieces[r].GetOrigin(), rtol=0, atol=1e-9)
        nvtest.check(same_frame and theirs.shape == mine.shape and np.array_equal(theirs, mine),
                     "rank %d: the .nvol decoded gives its piece %s value for value (largest difference %s)"
                     % (r, list(back.GetExtent()), float(np.abs(theirs - mine).max()) if theirs.shape == mine.shape
                        else "shape %s vs %s" % (theirs.shape, mine.shape)))
    Delete(opened)


def mpi_run():
    ranks, folder, reference = nvtest.mpi_test_start(__file__, out_dir, "OutputResolution")
    if reference is None:
        return
    for name, association, resolution in CASES:
        nc = compress(name, association, resolution)
        with nvtest.captured_messages() as messages:
            nc.UpdatePipeline()
        nvtest.check("ERROR" not in messages[0], "%s: no error: %r" % (name, messages[0][-300:]))
        pieces = check_case(nc, ranks, name, association, folder, reference)
        if name == "points":
            check_nvol(nc, ranks, pieces, folder)
        Delete(nc)


if SERIAL:
    serial_reference(sys.argv[sys.argv.index("--serial-reference") + 1])
else:
    mpi_run()
nvtest.finish()
