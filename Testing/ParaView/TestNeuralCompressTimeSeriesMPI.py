"""A time series under MPI (issue 23): `mpiexec -n 2` and `-n 4 pvbatch`, one network per rank and time step.

A drifting field written as a .pvd series of images (rank 0 writes it; every rank's reader reads its padded piece)
is compressed to a target PSNR over its time steps, cold and with WarmStart. Checks, on every rank:
- each time step's network of a rank starts from that rank's network of the time step before (NeuralWarmStart), and
  the warm run needs under 60% of the cold run's steps summed over the ranks (time steps 1..), each rank reaching
  the target on its piece (NeuralPiecePSNR within 1 dB);
- the global figures are per time step: the same on every rank, and NeuralPSNR equals numpy's over the whole decoded
  field of that time step (within 0.05 dB);
- stepping back to a trained time step shows every rank's cached network of that time step without a training step;
  the metrics table has a row per time step.
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkParallelCore import vtkMultiProcessController  # noqa: E402

N, STEPS = 48, 4
NET = dict(BatchSize=8192, Levels=10, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2", Threads=1,
           TargetCompressionRatio=1.5, Deterministic=0, TimeBudget=0, PSNRInterval=10, TrainingSteps=1500,
           TrainInBackground=0, Device="CPU")
TARGET = 40.0
WARM_SHARE = 0.6
GLOBAL_PSNR_DB = 0.05

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log


def pieces_of(nc, ranks):
    return [servermanager.Fetch(nc, r) for r in range(ranks)]


def run_series(reader, warm, times, ranks):
    """Every time step in turn; returns the filter and the steps each rank trained per time step."""
    nc = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", "f"], TargetPSNR=TARGET, WarmStart=warm, **NET)
    steps = []
    for i, t in enumerate(times):
        nc.UpdatePipeline(t)
        pieces = pieces_of(nc, ranks)
        steps.append([int(nvtest.field_value(p, "NeuralSteps")) for p in pieces])
        flags = [nvtest.field_value(p, "NeuralWarmStart") for p in pieces]
        expected = 1 if warm and i > 0 else 0
        check(all(f == expected for f in flags), "%s t=%g: NeuralWarmStart on every rank %s (expected %d)"
              % ("warm" if warm else "cold", t, flags, expected))
        piece_psnr = [nvtest.field_value(p, "NeuralPiecePSNR") for p in pieces]
        check(all(v >= TARGET - 1.0 for v in piece_psnr), "t=%g: every rank reached the target on its piece %s"
              % (t, [round(v, 2) for v in piece_psnr]))
        figures = {(nvtest.field_value(p, "NeuralPSNR"), nvtest.field_value(p, "NeuralTime")) for p in pieces}
        check(len(figures) == 1, "t=%g: the same global PSNR and time on every rank %s" % (t, figures))
    return nc, steps


def check_global_psnr(nc, ranks, t, original):
    """The decoded pieces of time step t assembled: NeuralPSNR is numpy's over the whole field."""
    nc.OutputMode = "Decoded, float32"
    nc.UpdatePipeline(t)
    decoded, _, figures = nvtest.assemble_pieces(pieces_of(nc, ranks), "f", [0, N - 1] * 3, original.shape)
    span = original.max() - original.min()
    numpy_psnr = 10.0 * math.log10(span ** 2 / float(np.mean((decoded - original) ** 2)))
    log("t=%g: global PSNR %.3f dB, numpy %.3f dB" % (t, figures[0], numpy_psnr))
    check(abs(figures[0] - numpy_psnr) <= GLOBAL_PSNR_DB, "t=%g: NeuralPSNR %.3f dB is numpy's %.3f dB over the "
          "whole decoded field of that time step" % (t, figures[0], numpy_psnr))
    nc.OutputMode = "Network only"


def check_cache(nc, ranks, times):
    """Stepping back: every rank shows its cached network of that time step, nothing is trained."""
    nc.UpdatePipeline(times[-1])
    before = [int(nvtest.field_value(p, "NeuralSteps")) for p in pieces_of(nc, ranks)]
    nc.SMProxy.UpdatePropertyInformation()
    total = nc.GetPropertyValue("TotalStepsTrained")
    for t in (times[1], times[0], times[2]):
        nc.UpdatePipeline(t)
        shown = [nvtest.field_value(p, "NeuralTime") for p in pieces_of(nc, ranks)]
        check(all(abs(s - t) < 1e-12 for s in shown), "t=%g: every rank shows its network of that time step %s"
              % (t, shown))
    nc.UpdatePipeline(times[-1])
    after = [int(nvtest.field_value(p, "NeuralSteps")) for p in pieces_of(nc, ranks)]
    nc.SMProxy.UpdatePropertyInformation()
    check(after == before and nc.GetPropertyValue("TotalStepsTrained") == total,
          "stepping back and forth trains nothing (steps %s -> %s)" % (before, after))
    metrics = nc.GetClientSideObject().GetOutputDataObject(2)
    rows = metrics.GetNumberOfRows() if metrics is not None else 0
    check(rows == len(times), "metrics: a row per time step (%d)" % rows)


def main():
    controller = vtkMultiProcessController.GetGlobalController()
    ranks = controller.GetNumberOfProcesses() if controller else 1
    if ranks not in (2, 4):
        nvtest.skip("this test runs under `mpiexec -n 2` or `-n 4 pvbatch` (here %d processes)" % ranks)
    folder = os.path.join(nvtest.output_dir(), "TimeSeriesMPI%d" % ranks)
    os.makedirs(folder, exist_ok=True)
    pvd, fields = nvtest.drifting_series(folder, N, STEPS)
    reader = PVDReader(FileName=pvd)
    times = list(reader.TimestepValues)
    check(len(times) == STEPS, "the series has %d time steps" % STEPS)
    cold, cold_steps = run_series(reader, 0, times, ranks)
    Delete(cold)
    warm, warm_steps = run_series(reader, 1, times, ranks)
    log("steps to %.0f dB per time step and rank: cold %r, warm %r" % (TARGET, cold_steps, warm_steps))
    cold_sum, warm_sum = sum(map(sum, cold_steps[1:])), sum(map(sum, warm_steps[1:]))
    check(warm_sum < WARM_SHARE * cold_sum, "warm start needs under %.0f%% of the cold steps (%d of %d, time steps "
          "1..%d, all ranks)" % (100 * WARM_SHARE, warm_sum, cold_sum, STEPS - 1))
    check_global_psnr(warm, ranks, times[2], fields[2])
    check_cache(warm, ranks, times)


main()
nvtest.finish()
