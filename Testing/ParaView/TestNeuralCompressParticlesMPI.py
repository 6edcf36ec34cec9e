"""Neural Compress of a particle set under MPI without a gather (issue 23): `mpiexec -n 2` and `-n 4 pvbatch`.

24000 random particles of the unit cube in 4 blocks of 6000 (x and y halves, a seed each) with f = sin 4x cos 3y +
0.5 z + 2; a Programmable Source gives each rank its own blocks (2 ranks: the x halves; 4 ranks: one block each),
so no rank ever holds another's particles. Neural Compress at SamplingDimensions 36^3 in Interpolate (cubic spline,
automatic radius: the whole set's, found without a gather) and Density (Wendland C2, ParticleRadius 0.12) modes:
each rank reconstructs the field on its k-d region of the serial lattice, adding its neighbours' kernel sums near
the cuts, and trains its own network on it. Rank 0 first runs the same pipelines on the whole set in a serial
pvbatch (this script with --serial-reference <folder>): the Neural Particle Field reconstruction on the same lattice
(saved as .npy) and, for Interpolate, a Neural Compress picture. Checks:
- no gather: each rank's NeuralPieceSourceSamples is its own particle count (fewer than the set's);
- the reconstruction each rank trained on equals the serial one over its own region (NeuralPieceTrainingSums: the
  samples inside the support exactly, the sum and the sum of squares of the values within 1e-5 of the range per
  sample); the decoded regions are NaN exactly where the serial reconstruction is;
- the global NeuralPSNR is numpy's over the assembled decoded field against the serial reconstruction (within
  0.05 dB), and that PSNR >= 35 dB;
- Interpolate: the composited picture against the serial Neural Compress picture >= 35 dB; a saved state brings every
  rank's network back without training, and one .nvol of them opens back on the ranks bit for bit.
"""
import builtins
import json
import math
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
BLOCKS, PER_BLOCK = 4, 6000
LATTICE = [36, 36, 36]
TRAINING = dict(SelectInputScalars=["POINTS", "f"], Device="CPU", Seed=7, Deterministic=1, TrainingSteps=300,
                BatchSize=16384, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2",
                Log2TableSize=14, Threads=1, PSNRInterval=0, TrainInBackground=0, OutputMode="Decoded, float32",
                SamplingDimensions=LATTICE)
# name, particle properties
CASES = (("interpolate", dict(ParticleField="Interpolate", ParticleKernel="Cubic Spline", ParticleRadius=0.0)),
         ("density", dict(ParticleField="Density", ParticleKernel="Wendland C2", ParticleRadius=0.12)))
RECONSTRUCTION_TOL = 1e-5  # of the range, per sample
GLOBAL_PSNR_DB = 0.05
DECODED_DB = 35.0
PICTURE_DB = 35.0
SIZE = [300, 300]
BACKGROUND = [0.32, 0.34, 0.43]

# Each rank's blocks: block b (x half b // 2, y half b % 2, seed 100 + b) belongs to piece b * pieces // 4.
SOURCE_SCRIPT = """
import numpy as np
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as sddp
from vtkmodules.util.numpy_support import numpy_to_vtk
info = self.GetOutputInformation(0)
piece = info.Get(sddp.UPDATE_PIECE_NUMBER()) if info.Has(sddp.UPDATE_PIECE_NUMBER()) else 0
pieces = info.Get(sddp.UPDATE_NUMBER_OF_PIECES()) if info.Has(sddp.UPDATE_NUMBER_OF_PIECES()) else 1
parts = []
for b in range(%d):
    if b * pieces // %d != piece:
        continue
    p = np.random.default_rng(100 + b).random((%d, 3))
    p[:, 0] = (b // 2 + p[:, 0]) * 0.5
    p[:, 1] = (b %% 2 + p[:, 1]) * 0.5
    parts.append(p)
p = np.concatenate(parts) if parts else np.zeros((0, 3))
out = self.GetPolyDataOutput()
points = vtkPoints()
points.SetData(numpy_to_vtk(np.ascontiguousarray(p), deep=True))
out.SetPoints(points)
f = numpy_to_vtk(np.sin(4.0 * p[:, 0]) * np.cos(3.0 * p[:, 1]) + 0.5 * p[:, 2] + 2.0, deep=True)
f.SetName("f")
out.GetPointData().AddArray(f)
""" % (BLOCKS, BLOCKS, PER_BLOCK)
INFORMATION_SCRIPT = """
from vtkmodules.vtkCommonExecutionModel import vtkAlgorithm
self.GetOutputInformation(0).Set(vtkAlgorithm.CAN_HANDLE_PIECE_REQUEST(), 1)
"""

nvtest.load_plugin(globals(), scripted=False)
out_dir = nvtest.output_dir()


def particles():
    return ProgrammableSource(OutputDataSetType="vtkPolyData", Script=SOURCE_SCRIPT,
                              ScriptRequestInformation=INFORMATION_SCRIPT)


def render(nc, path, span):
    view = nvtest.render_view(SIZE, BACKGROUND)
    display = Show(nc, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "f"))
    display.SetScalarBarVisibility(view, False)
    for tf in (GetColorTransferFunction("f"), GetOpacityTransferFunction("f")):
        tf.RescaleTransferFunction(span[0], span[1])
    nvtest.set_camera(view, [0.5 + 2.2, 0.5 - 1.6, 0.5 + 3.0], focal=(0.5, 0.5, 0.5))
    Render(view)
    nvtest.shot(view, path, SIZE)
    Delete(display)
    Delete(view)


def serial_reference(folder):
    source = particles()
    result = {}
    for name, props in CASES:
        field = NeuralParticleField(Input=source, SelectInputScalars=["POINTS", "f"], SamplingDimensions=LATTICE,
                                    **props)
        image = servermanager.Fetch(field)
        values = vtk_to_numpy(image.GetPointData().GetArray("f")).astype(np.float64)
        np.save(os.path.join(folder, name + ".npy"), values.reshape(LATTICE[2], LATTICE[1], LATTICE[0]))
        result[name] = dict(origin=list(image.GetOrigin()), spacing=list(image.GetSpacing()))
        Delete(field)
        if name == "interpolate":
            nc = NeuralCompress(Input=source, **dict(TRAINING, **props))
            nc.OutputMode = "Network only"
            nc.UpdatePipeline()
            valid = values[~np.isnan(values)]
            render(nc, os.path.join(folder, "serial.png"), (float(valid.min()), float(valid.max())))
            result[name]["psnr"] = nvtest.field_value(servermanager.Fetch(nc), "NeuralPSNR")
            Delete(nc)
    with open(os.path.join(folder, "serial.json"), "w") as f:
        json.dump(result, f)
    nvtest.log("serial reference: %s" % result)


def check_case(nc, ranks, name, reference):
    """Each rank's own particles and reconstruction; the global figures against numpy. Returns the assembled field."""
    check, log = nvtest.check, nvtest.log
    original = np.load(os.path.join(out_dir, name + ".npy"))
    inside = ~np.isnan(original)
    span = float(original[inside].max() - original[inside].min())
    whole = [0, LATTICE[0] - 1, 0, LATTICE[1] - 1, 0, LATTICE[2] - 1]
    pieces = []
    for r in range(ranks):
        piece = servermanager.Fetch(nc, r)
        pieces.append(piece)
        own = nvtest.field_value(piece, "NeuralPieceSourceSamples")
        expected = PER_BLOCK * len([b for b in range(BLOCKS) if b * ranks // BLOCKS == r])
        check(own == expected and own < BLOCKS * PER_BLOCK, "rank %d reconstructed from its own %s particles only "
              "(its blocks hold %d, the set %d)" % (r, own, expected, BLOCKS * PER_BLOCK))
        sums = piece.GetFieldData().GetArray("NeuralPieceTrainingSums")
        e = piece.GetExtent()
        region = original[e[4]:e[5] + 1, e[2]:e[3] + 1, e[0]:e[1] + 1]
        valid = region[~np.isnan(region)]
        ref = (float(valid.size), float(valid.sum()), float((valid ** 2).sum()))
        got = tuple(sums.GetValue(i) for i in range(3)) if sums else (math.nan,) * 3
        peak = float(np.abs(valid).max()) if valid.size else 1.0
        log("rank %d: region %s, reconstruction (inside, sum, sum of squares) %s; serial %s" % (r, list(e), got, ref))
        check(got[0] == ref[0], "rank %d: the reconstruction's support on its region is the serial one (%s vs %d "
              "samples)" % (r, got[0], ref[0]))
        samples = builtins.max(ref[0], 1.0)  # paraview.simple's names shadow max and abs
        check(builtins.abs(got[1] - ref[1]) <= RECONSTRUCTION_TOL * span * samples and
              builtins.abs(got[2] - ref[2]) <= 2.0 * peak * RECONSTRUCTION_TOL * span * samples,
              "rank %d: the reconstruction on its region is the serial one within %g of the range per sample "
              "(sum %+.3g, squares %+.3g)" % (r, RECONSTRUCTION_TOL, got[1] - ref[1], got[2] - ref[2]))
    decoded, extents, figures = nvtest.assemble_pieces(pieces, "f", whole, original.shape)
    psnr, max_error, model_bytes, networks = figures
    check(networks == ranks, "NeuralNetworks %s == %d ranks" % (networks, ranks))
    numpy_psnr, _ = nvtest.check_global_figures(decoded, original, psnr, max_error, GLOBAL_PSNR_DB,
                                                "the serial reconstruction")
    log("%s, %d ranks: model bytes %d" % (name, ranks, model_bytes))
    check(numpy_psnr >= DECODED_DB, "decoded vs the serial reconstruction %.2f dB >= %.0f dB"
          % (numpy_psnr, DECODED_DB))
    return original


def mpi_run():
    global out_dir
    check, log = nvtest.check, nvtest.log
    ranks, out_dir, reference = nvtest.mpi_test_start(__file__, out_dir, "ParticlesMPI")
    if reference is None:
        return
    source = particles()
    for name, props in CASES:
        nc = NeuralCompress(Input=source, **dict(TRAINING, **props))
        started = time.time()
        with nvtest.captured_messages() as messages:
            nc.UpdatePipeline()
        log("%s, %d ranks: UpdatePipeline %.1f s" % (name, ranks, time.time() - started))
        check("ERROR" not in messages[0], "no error: %r" % messages[0][-400:])
        original = check_case(nc, ranks, name, reference[name])
        if name == "interpolate":
            nc.OutputMode = "Network only"
            nc.UpdatePipeline()
            valid = original[~np.isnan(original)]
            render(nc, os.path.join(out_dir, "mpi.png"), (float(valid.min()), float(valid.max())))
            nvtest.compare_images(os.path.join(out_dir, "mpi.png"), os.path.join(out_dir, "serial.png"),
                                  PICTURE_DB, "%d-rank picture vs serial Neural Compress" % ranks)
            # Saved states and .nvol of the particle networks: every rank's own back without training.
            nvtest.check_ranks_restore(nc, ranks, lambda text: NeuralCompress(
                Input=source, **dict(TRAINING, **dict(props, TrainedNetworks=text))))
            nvtest.check_ranks_nvol(nc, ranks, os.path.join(out_dir, "particles-mpi%d.nvol" % ranks))
        Delete(nc)


if SERIAL:
    serial_reference(sys.argv[sys.argv.index("--serial-reference") + 1])
else:
    mpi_run()
nvtest.finish()
