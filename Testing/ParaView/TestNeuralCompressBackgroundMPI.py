"""Background training and the live view under MPI (issue 23), under `mpiexec -n 2 pvbatch`: one network per rank
of a Wavelet, each trained in the background (TrainInBackground, the filter's default). Checks:
- UpdatePipeline returns before training ends, on every rank;
- live updates as ParaView's live-source poll makes them (GetNeedsUpdate on rank 0 only, then an update of every
  rank): every rank's live network arrives, the global PSNR estimate is the same on both ranks and the global max
  error is unknown (NaN) while they train;
- Pause: both ranks pause and stay paused (steps unchanged 0.7 s later); Resume: a live update brings every rank a
  newer network and the composited picture changes (one render while paused, one after); WaitForTraining: both finish at
  exactly TrainingSteps, the final global figures are exact (the same on both ranks, NeuralMaxError known) and equal
  those of a second, blocking run of the same settings (Deterministic: the same networks, so the same PSNR and max
  error to the last bit; the network bytes differ by their training seconds);
- Stop on a long run: both ranks stop and their steps no longer advance.
Then the same live updates, pause, resume and stop for an out-of-core file (a 64^3 float32 .nhdr under a 0.4 MiB
MemoryBudget: each rank trains from its piece of the file, read in blocks while it trains; not compared with a blocking
run, an out-of-core run is not repeatable to the bit), and a refresh whose reader executed again does not prepare the
file again on any rank.
"""
import ctypes
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkParallelCore import vtkMultiProcessController  # noqa: E402

WHOLE = [0, 63, 0, 63, 0, 63]
STEPS = 3000
SETTINGS = dict(SelectInputScalars=["POINTS", "RTData"], Device="CPU", Seed=7, Deterministic=1, BatchSize=4096,
                Levels=8, FeaturesPerLevel=2, NetworkWidth=16, HiddenLayers=1, Loss="L2", Log2TableSize=12,
                Threads=1, PSNRInterval=100, TimeBudget=0, OutputMode="Network only")
SIZE = [200, 200]

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log
RANKS = 2


def states(nc):
    """(state, steps, network bytes, global PSNR) of every rank's output."""
    out = []
    for r in range(RANKS):
        data = servermanager.Fetch(nc, r)
        fd = data.GetFieldData()
        state = fd.GetAbstractArray("NeuralTrainingState")
        net = fd.GetArray("NeuralNetwork")
        steps = nvtest.field_value(data, "NeuralSteps")
        out.append((state.GetValue(0) if state else None, -1 if steps is None else int(steps),
                    bytes(vtk_to_numpy(net).tobytes()) if net is not None else None,
                    nvtest.field_value(data, "NeuralPSNR"), nvtest.field_value(data, "NeuralMaxError")))
    return out


def get_needs_update(nc):
    """vtkNeuralCompress::GetNeedsUpdate() on rank 0's filter, as ParaView's live-source poll calls it (a
    client-server message to the root data server; the plugin's class has no Python wrapping, so through ctypes)."""
    library = os.path.join(os.path.dirname(nvtest.plugin_path()), "libNeuralVolumeFilters.so")
    method = getattr(ctypes.CDLL(library), "_ZN17vtkNeuralCompress14GetNeedsUpdateEv")
    method.restype, method.argtypes = ctypes.c_bool, [ctypes.c_void_p]
    address = int(nc.GetClientSideObject().__this__.split("_")[1], 16)  # "_<hex address>_p_<class>"
    return method(address)


def live_update(nc):
    """What ParaView's live-source poll does: GetNeedsUpdate on rank 0 (it asks the other ranks), then an update."""
    needed = get_needs_update(nc)
    if needed:
        nc.SMProxy.MarkModified(nc.SMProxy)
        nc.UpdatePipeline()
    return needed


def out_of_core_file(out_dir):
    """A 64^3 float32 NRRD (detached) of a smooth field, written by the script's rank (the others read it)."""
    n = WHOLE[1] + 1
    z, y, x = np.meshgrid(*(np.linspace(0, 1, n),) * 3, indexing="ij")
    ((np.sin(7 * x) * np.cos(5 * y) + 0.5 * np.sin(9 * z + 3 * x)).astype(np.float32)).tofile(
        os.path.join(out_dir, "ooc.raw"))
    path = os.path.join(out_dir, "ooc.nhdr")
    with open(path, "w") as f:
        f.write("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nendian: little\n"
                "data file: ooc.raw\n" % (n, n, n))
    return path


def check_out_of_core(out_dir):
    reader = NeuralOutOfCoreReader(FileName=out_of_core_file(out_dir))
    settings = {k: v for k, v in SETTINGS.items() if k != "SelectInputScalars"}
    nc = NeuralCompress(Input=reader, TrainInBackground=1, TrainingSteps=STEPS, MemoryBudget=0.4, **settings)
    check_live(nc, out_dir)
    # The reader executing again is the same file: no new preparation (a value-range pass logged on stderr; this
    # script's rank 0 counts its own on fd 2).
    with nvtest.captured_stderr() as logged:
        for _ in range(2):
            reader.SMProxy.MarkModified(reader.SMProxy)
            reader.GetClientSideObject().Modified()
            reader.UpdatePipeline()
            time.sleep(0.3)
            live_update(nc)
            nc.SMProxy.MarkModified(nc.SMProxy)
            nc.UpdatePipeline()
        time.sleep(0.5)  # (a preparation runs on a background thread)
    passes = logged[0].count("value-range pass started")
    check(passes == 0, "out of core: the reader executing again does not prepare the file again (rank 0: %d "
          "value-range passes)" % passes)
    final = check_pause_resume(nc, out_dir, render_out_of_core)
    log("out of core, finished: %s" % [(s[0], s[1], s[3], s[4]) for s in final])
    Delete(nc)
    check_stop(reader, settings=dict(settings, MemoryBudget=0.4))
    Delete(reader)


def render(nc, path):
    return nvtest.wavelet_picture(nc, path, SIZE, WHOLE, (160.0, -120.0, 210.0))


def render_out_of_core(nc, path):
    """The out-of-core network's Neural Volume, coloured by the file's field ('ooc') over its range."""
    view = nvtest.render_view(SIZE, (0.32, 0.34, 0.43))
    display = Show(nc, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "ooc"))
    for tf in (GetColorTransferFunction("ooc"), GetOpacityTransferFunction("ooc")):
        tf.RescaleTransferFunction(-1.5, 1.5)
    centre = [(WHOLE[2 * a] + WHOLE[2 * a + 1]) / 2.0 for a in range(3)]
    nvtest.set_camera(view, [c + o for c, o in zip(centre, (160.0, -120.0, 210.0))], focal=centre)
    Render(view)
    nvtest.shot(view, path, SIZE)
    Delete(display)
    Delete(view)
    return nvtest.read_png(path)


def check_live(nc, out_dir):
    started = time.time()
    nc.UpdatePipeline()
    first = states(nc)
    log("UpdatePipeline returned after %.2f s: %s" % (time.time() - started, [(s[0], s[1]) for s in first]))
    check(all(s[0] in ("Starting", "Training", "Preparing") and s[1] < STEPS for s in first),
          "the update returns before training ends on every rank")
    # Live updates until both ranks show a network and some probes (PSNR estimates).
    deadline, updates = time.time() + 60.0, 0
    now = first
    while time.time() < deadline and not all(s[2] is not None and s[1] >= 300 and np.isfinite(s[3] or np.nan)
                                             for s in now):
        time.sleep(0.2)
        updates += live_update(nc)
        now = states(nc)
    log("after %d live updates: %s" % (updates, [(s[0], s[1], s[3]) for s in now]))
    check(updates > 0, "GetNeedsUpdate on rank 0 asked for updates while the ranks trained")
    check(all(s[2] is not None and s[1] >= 300 for s in now), "every rank's live network arrived (steps %s)"
          % [s[1] for s in now])
    check(now[0][3] == now[1][3] and np.isfinite(now[0][3]), "the global PSNR estimate is the same on both ranks "
          "(%s)" % [s[3] for s in now])
    check(all(s[4] is not None and not np.isfinite(s[4]) for s in now),
          "no global max error while the ranks train (%s)" % [s[4] for s in now])


def check_pause_resume(nc, out_dir, picture=render):
    nc.PauseTraining()
    nc.UpdatePipeline()
    paused = states(nc)
    check(all(s[0] == "Paused" for s in paused), "PauseTraining pauses every rank (%s)" % [s[0] for s in paused])
    # "Paused" shows at once; the chunk in flight (one step on the CPU) still completes: the steps are read once it has.
    time.sleep(0.3)
    live_update(nc)
    nc.SMProxy.MarkModified(nc.SMProxy)
    nc.UpdatePipeline()
    paused = states(nc)
    time.sleep(0.7)
    live_update(nc)
    nc.SMProxy.MarkModified(nc.SMProxy)
    nc.UpdatePipeline()
    later = states(nc)
    check(all(later[r][1] == paused[r][1] for r in range(RANKS)), "paused: steps stay (%s, then %s)"
          % ([s[1] for s in paused], [s[1] for s in later]))
    shots = [picture(nc, os.path.join(out_dir, "live_0.png"))]
    nc.ResumeTraining()
    for _ in range(2):  # a snapshot's bytes are written at most once a second, from one update to the next
        time.sleep(1.1)
        live_update(nc)
    resumed = states(nc)
    shots.append(picture(nc, os.path.join(out_dir, "live_1.png")))
    for r in range(RANKS):
        check(resumed[r][1] > later[r][1] and resumed[r][2] != later[r][2],
              "rank %d: resumed, a live update brings a newer network (steps %d -> %d)"
              % (r, later[r][1], resumed[r][1]))
    changed = float(np.mean(np.abs(shots[0] - shots[1]).max(axis=-1) > 2.0))
    log("pixels changed between the paused and the resumed picture: %.1f%%" % (100 * changed))
    check(changed > 0.01 and shots[1].std() > 5.0, "the composited picture shows the newer networks")
    nc.WaitForTraining()
    nc.UpdatePipeline()
    final = states(nc)
    log("finished: %s" % [(s[0], s[1], s[3], s[4]) for s in final])
    check(all(s[0] == "Finished" and s[1] == STEPS for s in final), "every rank finished at exactly %d steps (%s)"
          % (STEPS, [(s[0], s[1]) for s in final]))
    check(final[0][3] == final[1][3] and final[0][4] == final[1][4] and np.isfinite(final[0][4]),
          "the final global figures are exact and the same on both ranks (PSNR %s, max error %s)"
          % ([s[3] for s in final], [s[4] for s in final]))
    return final


def check_against_blocking(wavelet, final):
    blocking = NeuralCompress(Input=wavelet, TrainInBackground=0, TrainingSteps=STEPS, **SETTINGS)
    blocking.UpdatePipeline()
    ref = states(blocking)
    log("blocking run: %s" % [(s[0], s[1], s[3]) for s in ref])
    check(ref[0][3] == final[0][3] and ref[0][4] == final[0][4], "the global PSNR and max error are the blocking "
          "run's (%.6f / %.6f dB, %.6f / %.6f)" % (final[0][3], ref[0][3], final[0][4], ref[0][4]))
    Delete(blocking)


def check_stop(source, settings=SETTINGS):
    long_run = NeuralCompress(Input=source, TrainInBackground=1, TrainingSteps=10000000, **settings)
    long_run.UpdatePipeline()
    time.sleep(1.0)
    long_run.StopTraining()
    long_run.WaitForTraining()
    long_run.UpdatePipeline()
    stopped = states(long_run)
    time.sleep(0.7)
    live_update(long_run)
    long_run.SMProxy.MarkModified(long_run.SMProxy)
    long_run.UpdatePipeline()
    later = states(long_run)
    log("stopped: %s, later %s" % ([(s[0], s[1]) for s in stopped], [(s[0], s[1]) for s in later]))
    check(all(s[0] == "Stopped" for s in later) and all(later[r][1] == stopped[r][1] for r in range(RANKS)),
          "StopTraining stops every rank")
    Delete(long_run)


def main():
    controller = vtkMultiProcessController.GetGlobalController()
    ranks = controller.GetNumberOfProcesses() if controller else 1
    if ranks != RANKS:
        nvtest.skip("this test runs under `mpiexec -n 2 pvbatch` (here %d processes)" % ranks)
    nvtest.require_display()
    out_dir = os.path.join(nvtest.output_dir(), "BackgroundMPI")
    os.makedirs(out_dir, exist_ok=True)
    wavelet = Wavelet(WholeExtent=WHOLE)
    nc = NeuralCompress(Input=wavelet, TrainInBackground=1, TrainingSteps=STEPS, **SETTINGS)
    check_live(nc, out_dir)
    final = check_pause_resume(nc, out_dir)
    check_against_blocking(wavelet, final)
    check_stop(wavelet)
    Delete(nc)
    check_out_of_core(out_dir)


main()
nvtest.finish()
