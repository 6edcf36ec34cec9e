"""A parallel pvserver (`mpiexec -n 2 pvserver`) driven by a pvpython client (issue 23), then by the GUI
(NeuralVolumeGuiParallelScript.py: the view shows the composited picture): Neural Compress trains one
network per rank on a Wavelet [0,47]^3 (each rank its own piece, the same global PSNR on both and in the client's
data information), the Neural Volume
composited by the server matches the built-in session's serial picture (>= 35 dB), and a saved state loaded again
restores both ranks' networks without training (the same global PSNR).

Run by ctest as `pvpython --force-offscreen-rendering <this>` under xvfb; the launcher's variables of the client's
own MPI are removed from the server's environment."""
import os
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402

check, log = nvtest.check, nvtest.log
nvtest.require_display()
out_dir = nvtest.output_dir()
MPIEXEC = os.environ.get("NV_MPIEXEC", "")
if not MPIEXEC:
    nvtest.skip("no MPI launcher (NV_MPIEXEC)")
PIECES = ([0, 47, 0, 47, 0, 23], [0, 47, 0, 47, 23, 47])
SETTINGS = dict(SelectInputScalars=["POINTS", "RTData"], Device="CPU", Seed=7, Deterministic=1, TrainingSteps=300,
                BatchSize=16384, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2",
                Log2TableSize=12, Threads=1, PSNRInterval=0, TrainInBackground=0)
PICTURE_DB = 35.0
SIZE = [300, 300]


def start_server(log_path):
    """`mpiexec -n 2 pvserver` on a free loopback port; returns (process, port) once it accepts connections."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    launcher = ("OMPI_", "PMIX_", "PMI_", "OPAL_", "PRTE_", "ORTE_", "HYDRA_", "MPI_LOCALRANKID")
    env = {k: v for k, v in os.environ.items() if not k.startswith(launcher)}
    env["OMPI_MCA_mpi_yield_when_idle"] = "1"
    flags = os.environ.get("NV_MPIEXEC_FLAGS", "").split()
    server = subprocess.Popen([MPIEXEC] + flags + ["-n", "2", os.environ.get("NV_PVSERVER", "pvserver"),
                                                   "--server-port=%d" % port, "--force-offscreen-rendering"],
                              stdout=open(log_path, "w"), stderr=subprocess.STDOUT, env=env)
    deadline = time.time() + 90
    while time.time() < deadline and server.poll() is None:
        if "Accepting connection" in open(log_path).read():
            return server, port
        time.sleep(0.5)
    return server, None


def picture(nc, path):
    view = nvtest.render_view(SIZE)
    display = Show(nc, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "RTData"))
    display.SetScalarBarVisibility(view, False)
    nvtest.set_camera(view, [23.5 + 110.0, 23.5 - 80.0, 23.5 + 150.0], focal=(23.5, 23.5, 23.5))
    view.ResetCamera()
    Render(view)
    nvtest.shot(view, path, SIZE)
    Delete(display)
    Delete(view)


def figures(source, ranks):
    pieces = [servermanager.Fetch(source, r) for r in range(ranks)]
    return pieces, [nvtest.field_value(p, "NeuralPSNR") for p in pieces]


def remote_run():
    """Trains, draws, saves and loads a state on the 2-rank server; returns the global PSNR (None on failure)."""
    server, port = start_server(os.path.join(out_dir, "ParallelServer_pvserver.log"))
    if not check(port is not None, "the 2-rank pvserver accepts connections"):
        server.kill()
        return None
    psnr = None
    try:
        Connect("127.0.0.1", port)
        check(servermanager.ActiveConnection.GetNumberOfDataPartitions() == 2, "the server has 2 ranks")
        LoadPlugin(nvtest.plugin_path(), remote=True, ns=globals())
        LoadPlugin(nvtest.plugin_path(), remote=False, ns=globals())
        nc = NeuralCompress(Input=Wavelet(WholeExtent=[0, 47, 0, 47, 0, 47]), **SETTINGS)
        nc.UpdatePipeline()
        pieces, psnrs = figures(nc, 2)
        check([list(p.GetExtent()) for p in pieces] == [list(e) for e in PIECES] and psnrs[0] == psnrs[1],
              "each rank holds its piece, the global PSNR is the same on both (%s, %s)"
              % ([p.GetExtent() for p in pieces], psnrs))
        psnr = psnrs[0]
        # The client's Information panel: the field-data range of NeuralPSNR over the ranks is that one value.
        array = nc.GetDataInformation().GetFieldDataInformation().GetArrayInformation("NeuralPSNR")
        value_range = list(array.GetComponentRange(0)) if array else None
        check(value_range == [psnr, psnr], "the client's data information shows the global PSNR %s (range %s)"
              % (psnr, value_range))
        picture(nc, os.path.join(out_dir, "ParallelServer.png"))
        state = os.path.join(out_dir, "ParallelServer.pvsm")
        SaveState(state)
        ResetSession()  # the plugin stays loaded on the server and the client
        LoadState(state)
        loaded = FindSource("NeuralCompress1")
        loaded.UpdatePipeline()
        pieces, psnrs = figures(loaded, 2)
        restored = [nvtest.field_value(p, "NeuralRestored") for p in pieces]
        check(restored == [1, 1] and psnrs == [psnr, psnr], "the loaded state restores both ranks' networks without "
              "training (restored %s, PSNR %s, trained %s)" % (restored, psnrs, psnr))
        Disconnect()
    finally:
        nvtest.stop_process(server, 30)
    return psnr


def gui_run():
    """The GUI connected to a 2-rank pvserver (NeuralVolumeGuiParallelScript.py): the view shows the composited
    picture."""
    import shutil
    paraview = os.path.join(os.path.dirname(sys.executable), "paraview")
    paraview = paraview if os.path.exists(paraview) else shutil.which("paraview")
    if not paraview or not os.environ.get("DISPLAY"):
        log("SKIP (part): no paraview executable or display for the GUI")
        return
    server, port = start_server(os.path.join(out_dir, "ParallelServer_gui_pvserver.log"))
    if not check(port is not None, "the 2-rank pvserver for the GUI accepts connections"):
        server.kill()
        return
    env = dict(os.environ, NV_TEST_DIR=os.path.dirname(os.path.abspath(__file__)))
    stale = os.path.join(nvtest.output_dir(), "gui_parallel.log")
    if os.path.exists(stale):
        os.remove(stale)
    try:
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "NeuralVolumeGuiParallelScript.py")
        result = subprocess.run([paraview, "--dr", "--server-url=cs://127.0.0.1:%d" % port, "--script=" + script],
                                env=env, timeout=240, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        log(result.stdout.decode(errors="replace")[-3000:])
        checks = os.path.join(nvtest.output_dir(), "gui_parallel.log")
        if os.path.exists(checks):
            log("the GUI's checks:\n" + open(checks).read())
        check(result.returncode == 0, "the GUI on a 2-rank pvserver: every check passed (exit code %d)"
              % result.returncode)
    except subprocess.TimeoutExpired:
        check(False, "the GUI on a 2-rank pvserver finished in time")
    finally:
        nvtest.stop_process(server, 30)


psnr = remote_run()
if psnr is not None:
    Connect()  # the built-in session: the serial reference
    LoadPlugin(nvtest.plugin_path(), remote=False, ns=globals())
    serial = NeuralCompress(Input=Wavelet(WholeExtent=[0, 47, 0, 47, 0, 47]), **SETTINGS)
    serial.UpdatePipeline()
    log("global PSNR on 2 ranks %.3f dB, serial %.3f dB" % (psnr, nvtest.field_value(servermanager.Fetch(serial),
                                                                                       "NeuralPSNR")))
    picture(serial, os.path.join(out_dir, "ParallelServer_serial.png"))
    nvtest.compare_images(os.path.join(out_dir, "ParallelServer.png"),
                          os.path.join(out_dir, "ParallelServer_serial.png"), PICTURE_DB,
                          "2-rank pvserver picture vs serial")
gui_run()
nvtest.finish()
