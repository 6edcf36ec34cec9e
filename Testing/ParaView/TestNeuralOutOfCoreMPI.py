"""The out-of-core file source under MPI without a gather (issues 22 and 23): `mpiexec -n 2` and `-n 4 pvbatch`.

A procedural float32 volume of 96^3 (ooc_procedural.py, NRRD with a detached raw file) is opened with the Neural Out
Of Core Reader and compressed by Neural Compress on every rank: each rank asks the reader for its own block of the
file's extent plus 3 ghost layers (the image path's split, vtkNeuralCompressPartition.h), and its value-range pass,
block buffer, PSNR probe and exact passes read only that box of the file; it trains its own network, which is drawn
clipped to its piece and composited by ParaView. Rank 0 first runs the same pipeline in a serial pvbatch (this script
with --serial-reference <folder>, a subprocess). Checks:
- each rank read only its padded piece of the file: the box of every sample it read (NeuralFileReadBox) is its piece
  plus the ghost layers, and its bytes are < READ_SHARE[ranks] x the file's (the serial run reads the whole file);
- the global figures (NeuralPSNR, NeuralMaxError, NeuralModelBytes, NeuralNetworks) are the same on every rank and
  NeuralPSNR equals numpy's over the ranks' decoded pieces against the file (within 0.05 dB);
- the composited picture against the serial one >= 35 dB;
- a saved state's TrainedNetworks holds every rank's network and each rank restores its own without training;
- Save Data writes one .nvol of every rank's network, which the ranks open back (each its own network, bit for bit);
- MemoryBudget 0 (automatic) shares the host's memory among the ranks on it (the summary says so).
"""
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402
import ooc_procedural  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkParallelCore import vtkMultiProcessController  # noqa: E402

SERIAL = "--serial-reference" in sys.argv
DIMS = (96, 96, 96)
WHOLE = [0, DIMS[0] - 1, 0, DIMS[1] - 1, 0, DIMS[2] - 1]
GHOSTS = 3  # kPieceGhostLayers
SETTINGS = dict(Device="CPU", Seed=7, Deterministic=1, TrainingSteps=300, BatchSize=16384, Levels=8,
                FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2", Log2TableSize=14, Threads=1,
                PSNRInterval=0, TrainInBackground=0, MemoryBudget=16, OutputMode="Network only")
READ_SHARE = {2: 0.7, 4: 0.45}
PICTURE_DB = 35.0
GLOBAL_PSNR_DB = 0.05
SIZE = [300, 300]
BACKGROUND = [0.32, 0.34, 0.43]

nvtest.load_plugin(globals(), scripted=False)
out_dir = nvtest.output_dir()
check, log = nvtest.check, nvtest.log


def volume_path(folder):
    return os.path.join(folder, "ooc96.nhdr")


def file_values(folder):
    raw = os.path.splitext(volume_path(folder))[0] + ".raw"
    return np.fromfile(raw, dtype="<f4").astype(np.float64).reshape(DIMS[2], DIMS[1], DIMS[0])


def compress(folder, **extra):
    reader = NeuralOutOfCoreReader(FileName=volume_path(folder))
    nc = NeuralCompress(Input=reader, **dict(SETTINGS, **extra))
    return reader, nc


def field_name(reader):
    reader.UpdatePipelineInformation()
    return reader.GetPropertyValue("FieldName")


def render(nc, name, values, path):
    view = nvtest.render_view(SIZE, BACKGROUND)
    display = Show(nc, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", name))
    display.SetScalarBarVisibility(view, False)
    lut, pwf = GetColorTransferFunction(name), GetOpacityTransferFunction(name)
    lut.ApplyPreset("Cool to Warm", True)
    lut.AutomaticRescaleRangeMode = "Never"
    lut.RescaleTransferFunction(values.min(), values.max())
    pwf.RescaleTransferFunction(values.min(), values.max())
    nvtest.set_camera(view, [2.6, -1.9, 3.5], focal=(0.0, 0.0, 0.0))
    Render(view)
    nvtest.shot(view, path, SIZE)
    Delete(display)
    Delete(view)


def read_box(data):
    a = data.GetFieldData().GetArray("NeuralFileReadBox")
    return [int(a.GetValue(i)) for i in range(6)] if a is not None else None


def serial_reference(folder):
    reader, nc = compress(folder)
    nc.UpdatePipeline()
    data = servermanager.Fetch(nc)
    result = dict(psnr=nvtest.field_value(data, "NeuralPSNR"), model_bytes=nvtest.field_value(data, "NeuralModelBytes"),
                  box=read_box(data), box_bytes=nvtest.field_value(data, "NeuralFileReadBoxBytes"),
                  bytes_read=nvtest.field_value(data, "NeuralFileBytesRead"))
    render(nc, field_name(reader), file_values(folder), os.path.join(folder, "serial.png"))
    with open(os.path.join(folder, "serial.json"), "w") as f:
        json.dump(result, f)
    log("serial reference: %s" % result)


def padded(extent):
    """The piece's point extent grown by the ghost layers within the whole extent (what a rank reads)."""
    return [max(WHOLE[i], extent[i] - GHOSTS) if i % 2 == 0 else min(WHOLE[i], extent[i] + GHOSTS) for i in range(6)]


def check_reads(pieces, ranks, reference):
    file_bytes = DIMS[0] * DIMS[1] * DIMS[2] * 4
    check(reference["box"] == WHOLE and reference["box_bytes"] == file_bytes,
          "the serial run reads the whole file (box %s, %s bytes)" % (reference["box"], reference["box_bytes"]))
    for r, piece in enumerate(pieces):
        box, box_bytes = read_box(piece), nvtest.field_value(piece, "NeuralFileReadBoxBytes")
        total = nvtest.field_value(piece, "NeuralFileBytesRead")
        expected = padded(list(piece.GetExtent()))
        log("rank %d: piece %s, read box %s (%s bytes, %.3f of the file), %s bytes read in all (serial %s)"
            % (r, list(piece.GetExtent()), box, box_bytes, (box_bytes or 0) / float(file_bytes), total,
               reference["bytes_read"]))
        check(box == expected, "rank %d read only its padded piece of the file (box %s, padded piece %s)"
              % (r, box, expected))
        check(box_bytes is not None and box_bytes < READ_SHARE[ranks] * file_bytes,
              "rank %d read a box of %s bytes < %.2f x the file's %d" % (r, box_bytes, READ_SHARE[ranks], file_bytes))


def check_figures(nc, reader, ranks, folder, reference):
    """The decoded pieces against the file: global figures, numpy's PSNR. Returns (extents, global PSNR)."""
    name = field_name(reader)
    nc.OutputMode = "Decoded, float32"
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    check("ERROR" not in messages[0], "no error (decoded): %r" % messages[0][-400:])
    pieces = [servermanager.Fetch(nc, r) for r in range(ranks)]
    check_reads(pieces, ranks, reference)
    original = file_values(folder)
    decoded, extents, figures = nvtest.assemble_pieces(pieces, name, WHOLE, original.shape)
    psnr, max_error, model_bytes, networks = figures
    check(networks == ranks, "NeuralNetworks %s == %d ranks" % (networks, ranks))
    check(model_bytes == ranks * reference["model_bytes"], "NeuralModelBytes %s: the %d networks' sum (serial %s)"
          % (model_bytes, ranks, reference["model_bytes"]))
    span = original.max() - original.min()
    error = decoded - original
    numpy_psnr = 10.0 * math.log10(span ** 2 / float(np.mean(error ** 2)))
    numpy_max = float(np.abs(error).max())
    log("global PSNR %.3f dB (numpy %.3f), max error %.5f (numpy %.5f); serial %.3f dB"
        % (psnr, numpy_psnr, max_error, numpy_max, reference["psnr"]))
    check(abs(psnr - numpy_psnr) <= GLOBAL_PSNR_DB, "NeuralPSNR %.3f dB is numpy's over the decoded pieces against "
          "the file (%.3f dB) within %.2f dB" % (psnr, numpy_psnr, GLOBAL_PSNR_DB))
    check(abs(max_error - numpy_max) <= 1e-3 * max(1.0, numpy_max), "NeuralMaxError %.5f is numpy's %.5f"
          % (max_error, numpy_max))
    check(psnr >= reference["psnr"] - 1.0, "per-rank networks no worse than 1 dB below the serial network")
    info = nc.GetDataInformation()
    check(list(info.GetExtent()) == WHOLE, "data information: the whole extent %s" % str(info.GetExtent()))
    return extents, psnr


def check_automatic_budget(ranks):
    """MemoryBudget 0 (automatic) under MPI: the host's share divided among the ranks on it (rank 0's summary)."""
    reader, nc = compress(out_dir, MemoryBudget=0, TrainingSteps=1)
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    said = "shared by the %d ranks on this host" % ranks
    check(said in messages[0], "the automatic budget is shared by the ranks: %r in %r" % (said, messages[0][-600:]))
    Delete(nc)
    Delete(reader)


def mpi_run():
    global out_dir
    controller = vtkMultiProcessController.GetGlobalController()
    ranks = controller.GetNumberOfProcesses() if controller else 1
    if ranks not in READ_SHARE:
        nvtest.skip("this test runs under `mpiexec -n 2` or `-n 4 pvbatch` (here %d processes)" % ranks)
    out_dir = os.path.join(out_dir, "OutOfCoreMPI%d" % ranks)  # the 2- and 4-rank tests may run at once
    os.makedirs(out_dir, exist_ok=True)
    nvtest.require_display()
    ooc_procedural.write_volume(volume_path(out_dir), DIMS, "float32")
    reference = nvtest.run_serial_reference(__file__, out_dir)
    if reference is None:
        return
    reader, nc = compress(out_dir)
    started = time.time()
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    log("%d ranks: UpdatePipeline %.1f s" % (ranks, time.time() - started))
    check("ERROR" not in messages[0], "no error: %r" % messages[0][-400:])
    extents, psnr = check_figures(nc, reader, ranks, out_dir, reference)
    nvtest.check_ranks_restore(nc, ranks, lambda text: NeuralCompress(
        Input=reader, **dict(SETTINGS, OutputMode="Decoded, float32", TrainedNetworks=text)))
    nvtest.check_ranks_nvol(nc, ranks, os.path.join(out_dir, "ooc-mpi%d.nvol" % ranks))
    check_automatic_budget(ranks)
    render(nc, field_name(reader), file_values(out_dir), os.path.join(out_dir, "mpi.png"))
    nvtest.compare_images(os.path.join(out_dir, "mpi.png"), os.path.join(out_dir, "serial.png"), PICTURE_DB,
                          "%d-rank picture vs serial" % ranks)


if SERIAL:
    serial_reference(sys.argv[sys.argv.index("--serial-reference") + 1])
else:
    mpi_run()
nvtest.finish()
