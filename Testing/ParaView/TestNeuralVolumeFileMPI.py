""".nvol save/open of a distributed network (issue 23), under `mpiexec -n 2 pvbatch`.

Neural Compress trains one network per rank on its piece of a Wavelet; Save Data writes them into one file (rank 0
writes it; version 2: one entry per rank with its piece). Checks:
- the file holds 2 entries, pieces 0 and 1 of 2, version 2;
- opened by 2 ranks, rank r's output is rank r's network bit for bit, with the piece's extent and NeuralPieceBounds;
  the composited picture is the filter's (>= 60 dB: the same networks clipped to the same bounds);
- with Decoded float32, the reader's decoded piece is the filter's, value for value (CPU engine);
- opened by one process (a serial pvbatch, this script with --serial FOLDER), the distributed file gives one clear
  error ("open it with 2 ranks") and an empty output; the serial pvbatch also writes a file of a serial run
  (version 1), which opened by the 2 ranks goes to rank 0 alone (rank 1 outputs nothing: nothing is drawn twice);
- opened by 4 ranks (`mpiexec -n 4 pvbatch` of this script with --open FOLDER, where NV_MPIEXEC names the launcher):
  ranks 0 and 1 get pieces 0 and 1 bit for bit, ranks 2 and 3 nothing, no error.
"""
import json
import os
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkParallelCore import vtkMultiProcessController  # noqa: E402

SERIAL = "--serial" in sys.argv
OPEN = "--open" in sys.argv
WHOLE = [0, 47, 0, 47, 0, 47]
CENTRE = 23.5
SETTINGS = dict(SelectInputScalars=["POINTS", "RTData"], Device="CPU", Seed=7, Deterministic=1, TrainingSteps=120,
                BatchSize=8192, Levels=6, FeaturesPerLevel=2, NetworkWidth=16, HiddenLayers=1, Loss="L2",
                Log2TableSize=12, Threads=1, PSNRInterval=0, TrainInBackground=0, OutputMode="Network only")
SIZE = [240, 240]
PICTURE_DB = 60.0

nvtest.load_plugin(globals(), scripted=False)
out_dir = nvtest.output_dir()
check, log = nvtest.check, nvtest.log


def net_bytes(data):
    a = data.GetFieldData().GetArray("NeuralNetwork")
    return bytes(vtk_to_numpy(a).tobytes()) if a is not None else None


def array_values(data, name):
    a = data.GetFieldData().GetArray(name)
    return [a.GetValue(i) for i in range(a.GetNumberOfTuples())] if a is not None else None


def fetch_all(proxy, ranks):
    return [servermanager.Fetch(proxy, r) for r in range(ranks)] if ranks > 1 else [servermanager.Fetch(proxy)]


def file_header(path):
    """(version, entry count) of an .nvol file."""
    with open(path, "rb") as f:
        head = f.read(16)
    return struct.unpack("<II", head[8:16]) if head[:8] == b"NVOLFILE" else (None, None)


def render(source, path):
    view = nvtest.render_view(SIZE)
    display = Show(source, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "RTData"))
    display.SetScalarBarVisibility(view, False)
    values = nvtest.wavelet_values(WHOLE)
    for tf in (GetColorTransferFunction("RTData"), GetOpacityTransferFunction("RTData")):
        tf.RescaleTransferFunction(values.min(), values.max())
    GetColorTransferFunction("RTData").AutomaticRescaleRangeMode = "Never"
    Render(view)  # paraview.simple resets the camera at the session's first Render(): the camera is set after it
    nvtest.set_camera(view, [CENTRE + 120.0, CENTRE - 90.0, CENTRE + 160.0], focal=(CENTRE, CENTRE, CENTRE))
    Render(view)
    nvtest.shot(view, path, SIZE)
    Delete(display)
    Delete(view)


def serial_part(folder):
    """One process: the distributed file is refused with one clear error; a serial run's file is written."""
    result = {}
    with nvtest.captured_messages() as messages:
        reader = NeuralVolumeReader(FileName=[os.path.join(folder, "distributed.nvol")])
        reader.UpdatePipeline()
        data = servermanager.Fetch(reader)
    result["error"] = messages[0]
    result["points"] = data.GetNumberOfPoints()
    result["network"] = net_bytes(data) is not None
    Delete(reader)
    nc = NeuralCompress(Input=Wavelet(WholeExtent=WHOLE), **SETTINGS)
    nc.UpdatePipeline()
    SaveData(os.path.join(folder, "serial.nvol"), proxy=nc)
    result["serial_network"] = len(net_bytes(servermanager.Fetch(nc)) or b"")
    with open(os.path.join(folder, "serial.json"), "w") as f:
        json.dump(result, f)


def open_part(folder):
    """Under mpiexec -n 4: every rank's output of the 2-rank file, to open.json."""
    ranks = vtkMultiProcessController.GetGlobalController().GetNumberOfProcesses()
    with nvtest.captured_messages() as messages:
        reader = NeuralVolumeReader(FileName=[os.path.join(folder, "distributed.nvol")])
        reader.UpdatePipeline()
        opened = fetch_all(reader, ranks)
    result = dict(ranks=ranks, error=messages[0], pieces=[
        dict(extent=list(d.GetExtent()), network=(net_bytes(d) or b"").hex(),
             bounds=array_values(d, "NeuralPieceBounds")) for d in opened])
    with open(os.path.join(folder, "open.json"), "w") as f:
        json.dump(result, f)


def run_open_with_4(folder):
    mpiexec = os.environ.get("NV_MPIEXEC")
    if not mpiexec:
        log("SKIP (part): NV_MPIEXEC not set: no run of 4 ranks")
        return None
    launcher = ("OMPI_", "PMIX_", "PMI_", "OPAL_", "PRTE_", "ORTE_", "HYDRA_", "MPI_LOCALRANKID")
    env = {k: v for k, v in os.environ.items() if not k.startswith(launcher)}
    command = [mpiexec] + os.environ.get("NV_MPIEXEC_FLAGS", "").split() + [
        "-n", "4", os.environ.get("NV_PVBATCH", "pvbatch"), "--force-offscreen-rendering", os.path.abspath(__file__),
        "--open", folder]
    run = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=300)
    log("4-rank pvbatch: exit %d\n%s" % (run.returncode, run.stdout.decode(errors="replace")[-800:]))
    if not check(run.returncode == 0 and os.path.exists(os.path.join(folder, "open.json")), "the 4-rank run worked"):
        return None
    with open(os.path.join(folder, "open.json")) as f:
        return json.load(f)


def check_open_with_4(folder, trained):
    opened = run_open_with_4(folder)
    if opened is None:
        return
    check("ERROR" not in opened["error"], "4 ranks open the 2-rank file without an error (%s)" % opened["error"][-300:])
    pieces = opened["pieces"]
    for r in range(2):
        check(bytes.fromhex(pieces[r]["network"]) == net_bytes(trained[r]) and
              pieces[r]["extent"] == list(trained[r].GetExtent()),
              "4 ranks: rank %d has piece %d bit for bit (extent %s)" % (r, r, pieces[r]["extent"]))
    for r in (2, 3):
        check(not pieces[r]["network"] and pieces[r]["extent"] == [0, -1, 0, -1, 0, -1],
              "4 ranks: rank %d draws nothing (extent %s)" % (r, pieces[r]["extent"]))


def run_serial(folder):
    pvbatch = os.environ.get("NV_PVBATCH", "pvbatch")
    launcher = ("OMPI_", "PMIX_", "PMI_", "OPAL_", "PRTE_", "ORTE_", "HYDRA_", "MPI_LOCALRANKID")
    env = {k: v for k, v in os.environ.items() if not k.startswith(launcher)}
    started = time.time()
    run = subprocess.run([pvbatch, "--force-offscreen-rendering", os.path.abspath(__file__), "--serial", folder],
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=300)
    log("serial pvbatch: exit %d in %.1f s\n%s" % (run.returncode, time.time() - started,
                                                  run.stdout.decode(errors="replace")[-1500:]))
    if not check(run.returncode == 0 and os.path.exists(os.path.join(folder, "serial.json")), "the serial run worked"):
        return None
    with open(os.path.join(folder, "serial.json")) as f:
        return json.load(f)


def check_distributed_file(nc, path, ranks):
    """Save Data of the per-rank networks, open by as many ranks: every rank gets its own network and piece back."""
    trained = fetch_all(nc, ranks)
    with nvtest.captured_messages() as messages:
        SaveData(path, proxy=nc)
    check("ERROR" not in messages[0], "Save Data under MPI gives no error (%s)" % messages[0].strip()[-300:])
    version, entries = file_header(path)
    check(version == 2 and entries == ranks, "one file with one entry per rank (version %s, %s entries)"
          % (version, entries))
    with nvtest.captured_messages() as messages:
        reader = NeuralVolumeReader(FileName=[path])
        reader.UpdatePipeline()
        opened = fetch_all(reader, ranks)
    check("ERROR" not in messages[0], "opening it with %d ranks gives no error (%s)" % (ranks, messages[0].strip()))
    for r in range(ranks):
        same = net_bytes(opened[r]) == net_bytes(trained[r]) and net_bytes(trained[r]) is not None
        check(same, "rank %d opened its own network bit for bit (%d bytes)" % (r, len(net_bytes(trained[r]) or b"")))
        check(list(opened[r].GetExtent()) == list(trained[r].GetExtent()),
              "rank %d's piece extent %s (trained %s)" % (r, opened[r].GetExtent(), trained[r].GetExtent()))
        check(array_values(opened[r], "NeuralPieceBounds") == array_values(trained[r], "NeuralPieceBounds"),
              "rank %d's NeuralPieceBounds %s" % (r, array_values(opened[r], "NeuralPieceBounds")))
    check(list(reader.GetDataInformation().GetExtent()) == WHOLE, "the whole extent %s"
          % str(reader.GetDataInformation().GetExtent()))
    # Decoded: the reader's pieces are the filter's, value for value (the same networks on the same engine).
    reader.OutputMode = nc.OutputMode = "Decoded, float32"
    reader.Device = "CPU"
    reader.UpdatePipeline()
    nc.UpdatePipeline()
    for r, (a, b) in enumerate(zip(fetch_all(reader, ranks), fetch_all(nc, ranks))):
        x, y = a.GetPointData().GetArray("RTData"), b.GetPointData().GetArray("RTData")
        equal = x is not None and y is not None and np.array_equal(vtk_to_numpy(x), vtk_to_numpy(y))
        check(equal, "rank %d's decoded piece is the filter's (%s values)" % (r, x.GetNumberOfTuples() if x else None))
    reader.OutputMode = nc.OutputMode = "Network only"
    reader.UpdatePipeline()
    nc.UpdatePipeline()
    render(nc, os.path.join(out_dir, "trained.png"))
    render(reader, os.path.join(out_dir, "opened.png"))
    nvtest.compare_images(os.path.join(out_dir, "opened.png"), os.path.join(out_dir, "trained.png"), PICTURE_DB,
                          "the opened file's composited picture vs the trained networks'")
    Delete(reader)


def check_serial_file(path, ranks, serial):
    """A serial run's file opened by the ranks: rank 0 has the network, the others nothing."""
    check(file_header(path)[0] == 1, "a serial run's file stays version 1 (%s)" % str(file_header(path)))
    reader = NeuralVolumeReader(FileName=[path])
    reader.UpdatePipeline()
    opened = fetch_all(reader, ranks)
    check(len(net_bytes(opened[0]) or b"") == serial["serial_network"],
          "rank 0 opened the serial network (%d bytes)" % len(net_bytes(opened[0]) or b""))
    for r in range(1, ranks):
        check(opened[r].GetNumberOfPoints() == 0 and net_bytes(opened[r]) is None,
              "rank %d outputs nothing (%d points)" % (r, opened[r].GetNumberOfPoints()))
    Delete(reader)


def mpi_run():
    global out_dir
    controller = vtkMultiProcessController.GetGlobalController()
    ranks = controller.GetNumberOfProcesses() if controller else 1
    if ranks != 2:
        nvtest.skip("this test runs under `mpiexec -n 2 pvbatch` (here %d processes)" % ranks)
    nvtest.require_display()
    out_dir = os.path.join(out_dir, "VolumeFileMPI")
    os.makedirs(out_dir, exist_ok=True)
    nc = NeuralCompress(Input=Wavelet(WholeExtent=WHOLE), **SETTINGS)
    nc.UpdatePipeline()
    check_distributed_file(nc, os.path.join(out_dir, "distributed.nvol"), ranks)
    check_open_with_4(out_dir, fetch_all(nc, ranks))
    serial = run_serial(out_dir)
    if serial is None:
        return
    log("serial open of the distributed file: %s" % serial["error"].strip())
    check("open it with 2 ranks" in serial["error"] and serial["error"].count("ERROR") == 1,
          "one process opening the distributed file gets one clear error")
    check(serial["points"] == 0 and not serial["network"], "and an empty output")
    check_serial_file(os.path.join(out_dir, "serial.nvol"), ranks, serial)


if SERIAL:
    serial_part(sys.argv[sys.argv.index("--serial") + 1])
elif OPEN:
    open_part(sys.argv[sys.argv.index("--open") + 1])
else:
    mpi_run()
nvtest.finish()
