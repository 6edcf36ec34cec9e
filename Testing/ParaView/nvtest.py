"""Shared helpers of the NeuralVolume pvbatch tests.

Environment (set by Testing/ParaView/CMakeLists.txt):
  NV_PLUGIN        path of the built NeuralVolume plugin (.so)
  NV_TEST_OUTPUT   folder for images, state files and diff images
  NV_BASELINE_DIR  folder of the committed baseline images
  NV_DATA_DIR      folder of the real data sets (tests SKIP when it is absent)
"""
import contextlib
import math
import os
import sys
import tempfile

SKIP = 125  # ctest SKIP_RETURN_CODE

_failures = []


def plugin_path():
    path = os.environ.get("NV_PLUGIN", "")
    if not path or not os.path.exists(path):
        log("NV_PLUGIN does not name the built plugin: %r" % path)
        _exit(2)
    return path


_namespace = {}


# The tests written for the decoded field and a finished network ask for them: blocking training and a float32
# decoded output (the filter's defaults are background training and "Network only"; the online tests use those).
SCRIPTED = dict(TrainInBackground=0, OutputMode="Decoded, float32")


def load_plugin(namespace, scripted=True):
    """Loads the plugin into `namespace`; scripted: NeuralCompress(...) there defaults to SCRIPTED."""
    from paraview.simple import LoadPlugin
    LoadPlugin(plugin_path(), remote=False, ns=namespace)
    if scripted:
        stock = namespace["NeuralCompress"]

        def NeuralCompress(*args, **kwargs):
            return stock(*args, **dict(SCRIPTED, **kwargs))
        namespace["NeuralCompress"] = NeuralCompress
    _namespace.update(namespace)


def output_dir():
    path = os.environ.get("NV_TEST_OUTPUT", os.path.join(os.getcwd(), "nv-test-output"))
    os.makedirs(path, exist_ok=True)
    return path


def log(msg):
    sys.stderr.write(str(msg) + "\n")
    sys.stderr.flush()


def check(condition, message):
    """Record a failed assertion (the test goes on, and fails at finish())."""
    if not condition:
        _failures.append(message)
        log("FAIL: " + message)
    return condition


def check_close(value, expected, tol, message):
    return check(abs(value - expected) <= tol,
                 "%s: %r != %r (tolerance %r)" % (message, value, expected, tol))


def _exit(code):
    # sys.exit() from a pvbatch script tears the views down in an order that makes GLX fail
    # ("GLXBadContext") and pvbatch return 1; leave without the teardown instead.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def finish():
    """Last statement of a test: exit 1 when a check failed, else end the script normally."""
    if _failures:
        log("%d check(s) failed" % len(_failures))
        _exit(1)
    log("all checks passed")


def fail_on_exception(function):
    """For callbacks inside the GUI: an exception ends the GUI with a failure instead of leaving it running."""
    def wrapped(*args):
        try:
            return function(*args)
        except Exception:
            import traceback
            traceback.print_exc()
            _exit(1)
    return wrapped


@contextlib.contextmanager
def pvserver(executable, log_name):
    """A pvserver on a free loopback port (output to log_name in the output folder: an unread pipe would block it),
    ready to connect; yields (process, port) and terminates it at the end."""
    import socket
    import subprocess
    import time
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    with open(os.path.join(output_dir(), log_name), "w") as server_log:
        server = subprocess.Popen([executable, "--server-port=%d" % port, "--force-offscreen-rendering"],
                                  stdout=server_log, stderr=subprocess.STDOUT)
        try:
            deadline = time.time() + 60
            while time.time() < deadline and server.poll() is None:
                try:
                    socket.create_connection(("127.0.0.1", port), timeout=1).close()
                    break
                except OSError:
                    time.sleep(0.5)
            yield server, port
        finally:
            stop_process(server, 20)


def stop_process(process, seconds):
    """Terminate a server process, killing it when it has not ended within `seconds`."""
    import subprocess
    process.terminate()
    try:
        process.wait(timeout=seconds)
    except subprocess.TimeoutExpired:
        process.kill()


def skip(reason):
    log("SKIP: " + reason)
    _exit(SKIP)


def require_display():
    if not os.environ.get("DISPLAY"):
        skip("no X display: run the rendering tests under xvfb-run")


@contextlib.contextmanager
def captured_messages():
    """Collect everything VTK prints (errors, warnings, text) while the block runs.

    Yields a list that holds one string (the captured text) once the block exits. pvbatch routes
    Python's print() through the output window too, so the tests log to stderr instead."""
    from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow
    previous = vtkOutputWindow.GetInstance()
    previous.Register(None)
    catcher = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(catcher)
    result = []
    try:
        yield result
    finally:
        vtkOutputWindow.SetInstance(previous)
        previous.UnRegister(None)
        result.append(catcher.GetOutput())


@contextlib.contextmanager
def captured_stderr():
    """Collect what this process writes on file descriptor 2 while the block runs (VTK's logger lines, e.g. the
    out-of-core phases a filter logs from its background threads). Yields a list that holds the text once the block
    exits."""
    sys.stderr.flush()
    saved, captured = os.dup(2), tempfile.TemporaryFile()
    os.dup2(captured.fileno(), 2)
    result = []
    try:
        yield result
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        captured.seek(0)
        result.append(captured.read().decode(errors="replace"))
        captured.close()


def field_value(data, name):
    array = data.GetFieldData().GetAbstractArray(name)
    if array is None or array.GetNumberOfTuples() < 1:
        return None
    value = array.GetVariantValue(0)
    return value.ToString() if array.IsA("vtkStringArray") else value.ToDouble()


def read_png(path):
    """RGB pixels of a PNG as a float numpy array (rows, cols, 3)."""
    import numpy as np
    from vtkmodules.vtkIOImage import vtkPNGReader
    from vtkmodules.util.numpy_support import vtk_to_numpy
    reader = vtkPNGReader()
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    dims = image.GetDimensions()
    pixels = vtk_to_numpy(image.GetPointData().GetScalars()).astype(np.float64)
    return pixels.reshape(dims[1], dims[0], -1)[:, :, :3]


def image_psnr(a, b):
    import numpy as np
    if a.shape != b.shape:
        return -math.inf
    mse = float(np.mean((a - b) ** 2))
    return math.inf if mse == 0 else 10.0 * math.log10(255.0 ** 2 / mse)


def block_means(pixels, k):
    """Means of k x k pixel blocks (Monte Carlo images: compares the picture, not where its fireflies fell)."""
    rows, cols = pixels.shape[0] // k * k, pixels.shape[1] // k * k
    return pixels[:rows, :cols].reshape(rows // k, k, cols // k, k, pixels.shape[2]).mean(axis=(1, 3))


def compare_images(test_png, reference_png, threshold_db, label, block=1):
    """Check image PSNR >= threshold_db (on block x block means when block > 1); writes an amplified difference
    image on failure."""
    import numpy as np
    a = read_png(test_png)
    b = read_png(reference_png)
    psnr = image_psnr(block_means(a, block), block_means(b, block)) if block > 1 and a.shape == b.shape \
        else image_psnr(a, b)
    log("%s: image PSNR %.2f dB (threshold %.1f)" % (label, psnr, threshold_db))
    if not check(psnr >= threshold_db, "%s: image PSNR %.2f dB < %.1f dB (%s vs %s)"
                 % (label, psnr, threshold_db, test_png, reference_png)):
        if a.shape == b.shape:
            write_diff(np.abs(a - b), os.path.splitext(test_png)[0] + ".diff.png")
    return psnr


def write_diff(diff, path):
    import numpy as np
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOImage import vtkPNGWriter
    from vtkmodules.util.numpy_support import numpy_to_vtk
    scaled = np.clip(diff * 4.0, 0, 255).astype(np.uint8)
    rows, cols = scaled.shape[:2]
    image = vtkImageData()
    image.SetDimensions(cols, rows, 1)
    array = numpy_to_vtk(scaled.reshape(-1, 3), deep=1)
    image.GetPointData().SetScalars(array)
    writer = vtkPNGWriter()
    writer.SetFileName(path)
    writer.SetInputData(image)
    writer.Write()
    log("difference image written to " + path)


def point_image(values, dims, name="f", vtk_type=None):
    """A TrivialProducer of an image of `dims` samples (None: an empty extent) carrying `values` (a numpy array, 3-D
    ones raveled x fastest; None: no array) as the point array `name`, of `vtk_type` when given."""
    import numpy as np
    from paraview.simple import TrivialProducer
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    image = vtkImageData()
    if dims is None:
        image.SetExtent(0, -1, 0, -1, 0, -1)
    else:
        image.SetDimensions(*dims)
    if values is not None:
        v = np.ascontiguousarray(values)
        array = numpy_to_vtk(v.ravel() if v.ndim == 3 else v, deep=True, array_type=vtk_type)
        array.SetName(name)
        image.GetPointData().AddArray(array)
    producer = TrivialProducer()
    producer.GetClientSideObject().SetOutput(image)
    return producer


# --- rendering helpers of the Neural Volume tests ------------------------------------------------

def wavelet_values(whole):
    """RTData of the Wavelet of extent `whole` in image order (z, y, x), float64, computed by VTK outside the session's
    pipeline (the reference of the tests that split it over MPI ranks)."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkImagingCore import vtkRTAnalyticSource
    src = vtkRTAnalyticSource()
    src.SetWholeExtent(*whole)
    src.Update()
    dims = [whole[1] - whole[0] + 1, whole[3] - whole[2] + 1, whole[5] - whole[4] + 1]
    values = vtk_to_numpy(src.GetOutput().GetPointData().GetArray("RTData")).astype(np.float64)
    return values.reshape(dims[2], dims[1], dims[0])


# A small network of the 64^3 Wavelet that trains in a few seconds on two cores (~38 dB). Float16 storage: the render
# tests' image baselines are of this network (the default Automatic storage would code an automatic size in 8 bits,
# another table and another picture).
WAVELET_NETWORK = dict(TrainingSteps=300, BatchSize=16384, Levels=12, FeaturesPerLevel=2, NetworkWidth=32,
                       HiddenLayers=2, Loss="L2", TargetCompressionRatio=5, Threads=2, PSNRInterval=0,
                       StoragePrecision="Float16")


def wavelet_network(half=31, **overrides):
    """A Wavelet on [-half, half+1]^3 and a Neural Compress of its RTData (fixed seed: deterministic)."""
    from paraview.simple import Wavelet
    wavelet = Wavelet(WholeExtent=[-half, half + 1] * 3)
    params = dict(WAVELET_NETWORK)
    params.update(overrides)
    network = _namespace["NeuralCompress"](Input=wavelet, SelectInputScalars=["POINTS", "RTData"], **params)
    network.UpdatePipeline()
    return wavelet, network


def wavelet_view(size, threshold_fraction):
    """The Wavelet network (wavelet_network) shown in a render view of `size`: Cool to Warm over RTData's range
    (locked), opacity 0 below `threshold_fraction` of the range and rising to 1 at its top, no scalar bar.
    Returns (wavelet, network, view, display)."""
    wavelet, network = wavelet_network()
    vmin, vmax = wavelet.PointData["RTData"].GetRange()
    view = render_view(size)
    display = show_styled(network, view, "RTData", vmin, vmax, threshold_fraction)
    return wavelet, network, view, display


def show_styled(source, view, array, vmin, vmax, threshold_fraction=None):
    """`source` shown in `view` without a scalar bar, `array` coloured Cool to Warm over [vmin, vmax] (locked); the
    opacity ramps over that range, or (threshold_fraction) is 0 below that share of it and rises to 1 at its top."""
    from paraview.simple import GetColorTransferFunction, GetOpacityTransferFunction, Show
    display = Show(source, view)
    display.SetScalarBarVisibility(view, False)
    lut = GetColorTransferFunction(array)
    lut.ApplyPreset("Cool to Warm", True)
    lut.RescaleTransferFunction(vmin, vmax)
    lut.AutomaticRescaleRangeMode = "Never"
    opacity = GetOpacityTransferFunction(array)
    if threshold_fraction is None:
        opacity.RescaleTransferFunction(vmin, vmax)
    else:
        threshold = vmin + threshold_fraction * (vmax - vmin)
        opacity.Points = [vmin, 0.0, 0.5, 0.0, threshold, 0.0, 0.5, 0.0, vmax, 1.0, 0.5, 0.0]
    return display


def render_view(size, background=(0.32, 0.34, 0.43)):
    """A render view of a fixed size and plain background, no orientation axes."""
    from paraview.simple import CreateView
    view = CreateView("RenderView")
    view.ViewSize = list(size)
    view.OrientationAxesVisibility = 0
    view.Background = list(background)
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    return view


def wavelet_picture(network, path, size, whole, eye_offset, background=(0.32, 0.34, 0.43)):
    """The Neural Volume of a network of a Wavelet's RTData (its maps over the Wavelet's whole range on `whole`), seen
    from the extent's centre plus `eye_offset`, saved to `path`: its pixels (read_png)."""
    from paraview.simple import (ColorBy, Delete, GetColorTransferFunction, GetOpacityTransferFunction, Render,
                                 Show)
    view = render_view(size, background)
    display = Show(network, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", "RTData"))
    values = wavelet_values(whole)
    for tf in (GetColorTransferFunction("RTData"), GetOpacityTransferFunction("RTData")):
        tf.RescaleTransferFunction(values.min(), values.max())
    Render(view)
    centre = [(whole[2 * a] + whole[2 * a + 1]) / 2.0 for a in range(3)]
    set_camera(view, [c + o for c, o in zip(centre, eye_offset)], focal=centre)
    Render(view)
    shot(view, path, size)
    Delete(display)
    Delete(view)
    return read_png(path)


def set_camera(view, position, focal=(0.5, 0.5, 0.5), up=(0.0, 0.0, 1.0), angle=30.0, parallel=0, scale=50.0):
    view.CameraPosition = list(position)
    view.CameraFocalPoint = list(focal)
    view.CameraViewUp = list(up)
    view.CameraViewAngle = angle
    view.CameraParallelProjection = parallel
    view.CameraParallelScale = scale


def info(display, name):
    """Value(s) of an information property of a representation (a scalar for one element)."""
    display.SMProxy.UpdatePropertyInformation()
    prop = display.SMProxy.GetProperty(name)
    values = [prop.GetElement(i) for i in range(prop.GetNumberOfElements())]
    return values[0] if len(values) == 1 else values


def shot(view, path, size):
    from paraview.simple import SaveScreenshot
    SaveScreenshot(path, view, ImageResolution=list(size))
    return path


def region_psnr(a, b, mask):
    """PSNR over the pixels where mask is true (inf when equal there, -inf when the mask is empty)."""
    import numpy as np
    if not mask.any():
        return -math.inf
    mse = float(np.mean((a[mask] - b[mask]) ** 2))
    return math.inf if mse == 0 else 10.0 * math.log10(255.0 ** 2 / mse)


def is_uniform(pixels, tolerance=1.0):
    return float((pixels.max(axis=(0, 1)) - pixels.min(axis=(0, 1))).max()) <= tolerance


def baseline(test_png, name, threshold_db, label, block=1):
    """Compare with Baseline/<name>.png (compare_images), or write it when NV_GENERATE_BASELINE is set. A missing
    baseline fails."""
    import shutil
    directory = os.environ.get("NV_BASELINE_DIR", os.path.join(os.path.dirname(__file__), "Baseline"))
    reference = os.path.join(directory, name + ".png")
    if os.environ.get("NV_GENERATE_BASELINE"):
        os.makedirs(directory, exist_ok=True)
        shutil.copyfile(test_png, reference)
        log("baseline written to " + reference)
        return math.inf
    if not check(os.path.exists(reference), "%s: baseline %s exists" % (label, reference)):
        return -math.inf
    return compare_images(test_png, reference, threshold_db, label, block)


def mpi_test_start(script, out_dir, tag, extra=()):
    """The prologue of the 2- and 4-rank MPI tests: their rank count (a SKIP otherwise), their output folder
    (out_dir/<tag><ranks>: the 2- and 4-rank tests may run at once), a display, and the serial reference run of
    `script` (run_serial_reference, with the arguments `extra`; with --serial-done on the command line the reference
    that `script --serial-reference <folder>` wrote there beforehand, where a pvbatch started by an MPI rank cannot
    initialise MPI: Open MPI unpacked on the GPU machine). Returns (ranks, folder, reference); reference None: the
    reference failed (checked)."""
    from vtkmodules.vtkParallelCore import vtkMultiProcessController
    controller = vtkMultiProcessController.GetGlobalController()
    ranks = controller.GetNumberOfProcesses() if controller else 1
    if ranks not in (2, 4):
        skip("this test runs under `mpiexec -n 2` or `-n 4 pvbatch` (here %d processes)" % ranks)
    folder = os.path.join(out_dir, "%s%d" % (tag, ranks))
    os.makedirs(folder, exist_ok=True)
    require_display()
    if "--serial-done" in sys.argv:
        import json
        done = os.path.join(folder, "serial.json")
        if not check(os.path.exists(done), "the serial reference made beforehand exists (%s)" % done):
            return ranks, folder, None
        with open(done) as f:
            return ranks, folder, json.load(f)
    return ranks, folder, run_serial_reference(script, folder, extra)


def run_serial_reference(script, out_dir, extra=()):
    """The MPI tests' serial reference: `script --serial-reference out_dir [extra...]` in a pvbatch of its own, without
    the MPI launcher's environment (it would make that pvbatch a rank); returns its serial.json, or None (checked) on
    failure."""
    import json
    import subprocess
    import time
    pvbatch = os.environ.get("NV_PVBATCH", "pvbatch")
    launcher = ("OMPI_", "PMIX_", "PMI_", "OPAL_", "PRTE_", "ORTE_", "HYDRA_", "MPI_LOCALRANKID")
    # Where Open MPI itself lives (an unpacked one: Testing/Gpu/paraview_gpu_env.sh) is not the launcher's: the
    # reference's MPI_Init as a singleton needs it.
    installation = ("OPAL_PREFIX", "OMPI_MCA_mca_base_param_files", "PMIX_MCA_mca_base_component_path")
    env = {k: v for k, v in os.environ.items() if not k.startswith(launcher) or k in installation}
    started = time.time()
    serial = subprocess.run([pvbatch, "--force-offscreen-rendering", os.path.abspath(script), "--serial-reference",
                             out_dir] + list(extra), env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=500)
    log("serial reference pvbatch: exit %d in %.1f s\n%s" % (serial.returncode, time.time() - started,
                                                             serial.stdout.decode(errors="replace")[-2000:]))
    if not check(serial.returncode == 0 and os.path.exists(os.path.join(out_dir, "serial.json")),
                 "the serial reference run succeeded"):
        return None
    with open(os.path.join(out_dir, "serial.json")) as f:
        return json.load(f)


def exclusive_slices(extent, whole):
    """numpy slices (z, y, x) of the samples a piece of point extent `extent` owns alone (a shared upper plane
    belongs to the next piece)."""
    out = []
    for a in (2, 1, 0):
        lo, hi = extent[2 * a] - whole[2 * a], extent[2 * a + 1] - whole[2 * a]
        if extent[2 * a + 1] < whole[2 * a + 1]:
            hi -= 1
        out.append(slice(lo, hi + 1))
    return tuple(out)


def assemble_pieces(pieces, name, whole, shape):
    """The MPI tests' decoded pieces (one vtkImageData a rank, fetched) placed into one array of `shape` (z, y, x) over
    the point extent `whole`, each sample from the piece that owns it alone; checks that every piece carries its own
    network, that the pieces partition `whole` and that the global figures are the same on every rank. Returns
    (decoded, extents, figures: NeuralPSNR, NeuralMaxError, NeuralModelBytes, NeuralNetworks of the first)."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy
    decoded = np.zeros(shape)
    owners = np.zeros(shape, dtype=np.int32)
    extents, figures = [], []
    for rank, piece in enumerate(pieces):
        extent = list(piece.GetExtent())
        extents.append(extent)
        fd = piece.GetFieldData()
        networks = len([i for i in range(fd.GetNumberOfArrays()) if fd.GetArrayName(i) == "NeuralNetwork"])
        check(networks == 1, "rank %d's output carries its own network (%d)" % (rank, networks))
        figures.append(tuple(field_value(piece, k) for k in
                             ("NeuralPSNR", "NeuralMaxError", "NeuralModelBytes", "NeuralNetworks")))
        dims = [extent[1] - extent[0] + 1, extent[3] - extent[2] + 1, extent[5] - extent[4] + 1]
        values = vtk_to_numpy(piece.GetPointData().GetArray(name)).astype(np.float64)
        values = values.reshape(dims[2], dims[1], dims[0])
        own = exclusive_slices(extent, whole)
        offset = [extent[4 - 2 * i] - whole[4 - 2 * i] for i in range(3)]
        decoded[own] = values[tuple(slice(s.start - offset[i], s.stop - offset[i]) for i, s in enumerate(own))]
        owners[own] += 1
        log("rank %d: extent %s, piece PSNR %.3f dB" % (rank, extent, field_value(piece, "NeuralPiecePSNR")))
    check(np.all(owners == 1), "the ranks' pieces partition the whole extent (samples owned 0 times: %d, twice or "
          "more: %d)" % (int(np.sum(owners == 0)), int(np.sum(owners > 1))))
    check(len(set(figures)) == 1, "the global figures are the same on every rank: %s" % figures)
    return decoded, extents, figures[0]


_RSS_SCRIPT = ("import resource\nfrom vtkmodules.vtkCommonCore import vtkDoubleArray\n"
               "out = self.GetOutput()\nfor name, value in (('rss', [int(l.split()[1]) * 1024.0 for l in "
               "open('/proc/self/status') if l.startswith('VmRSS')][0]), ('peak', "
               "resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0)):\n"
               "    a = vtkDoubleArray()\n    a.SetName(name)\n    a.InsertNextValue(value)\n    out.AddColumn(a)\n")


def rank_memory(ranks):
    """(current, peak) RSS bytes of every rank, measured now by a programmable source that runs on each (the MPI tests
    and Testing/Benchmarks/distributed_scaling.py)."""
    import __main__
    from paraview import servermanager
    from paraview.simple import Delete, ProgrammableSource
    # The programmable source runs its script in the main script's namespace on rank 0, importing numpy_interface's
    # algorithms (max, log, ... that reduce over the ranks): that namespace is restored afterwards.
    namespace = vars(__main__)
    saved = dict(namespace)
    source = ProgrammableSource(OutputDataSetType="vtkTable", Script=_RSS_SCRIPT)
    source.UpdatePipeline()
    tables = [servermanager.Fetch(source, r) for r in range(ranks)] if ranks > 1 else [servermanager.Fetch(source)]
    Delete(source)
    for name in [k for k in namespace if k not in saved]:
        del namespace[name]
    namespace.update(saved)
    return [(t.GetColumnByName("rss").GetValue(0), t.GetColumnByName("peak").GetValue(0)) for t in tables]


def check_ranks_restore(nc, ranks, make_restored):
    """Under MPI: a saved state's TrainedNetworks (rank 0's, as a client reads it) holds every rank's network, and a
    Neural Compress given it (`make_restored(text)`, the same input and settings) brings each rank's own back without
    training, with the same global PSNR."""
    from paraview import servermanager
    from paraview.simple import Delete
    nc.UpdatePropertyInformation()
    text = nc.GetPropertyValue("TrainedNetworksInfo")
    entries = text.count(";") if text.startswith("nvnet1") else -1
    check(entries == ranks, "TrainedNetworks holds the %d ranks' networks (%d entries)" % (ranks, entries))
    psnr = field_value(servermanager.Fetch(nc, 0), "NeuralPSNR")
    restored = make_restored(text)
    restored.UpdatePipeline()
    for r in range(ranks):
        piece = servermanager.Fetch(restored, r)
        check(field_value(piece, "NeuralRestored") == 1 and field_value(piece, "NeuralPSNR") == psnr,
              "rank %d restored its network from the state without training (restored %s, PSNR %s dB)"
              % (r, field_value(piece, "NeuralRestored"), field_value(piece, "NeuralPSNR")))
    Delete(restored)


def check_ranks_nvol(nc, ranks, path):
    """Under MPI: Save Data writes one .nvol of every rank's network (Network only), which as many ranks open back,
    each its own network bit for bit with its piece's extent."""
    from paraview import servermanager
    from paraview.simple import Delete, SaveData

    from vtkmodules.util.numpy_support import vtk_to_numpy

    def network_bytes(data):
        array = data.GetFieldData().GetArray("NeuralNetwork")
        return vtk_to_numpy(array).tobytes() if array is not None else None

    if os.path.exists(path):
        os.remove(path)
    nc.OutputMode = "Network only"
    nc.UpdatePipeline()
    SaveData(path, proxy=nc)
    check(os.path.exists(path), ".nvol of the %d ranks' networks written (%d bytes)"
          % (ranks, os.path.getsize(path) if os.path.exists(path) else 0))
    opened = _namespace["NeuralVolumeReader"](FileName=path)  # the plugin's proxy (load_plugin)
    opened.UpdatePipeline()
    for r in range(ranks):
        mine, back = servermanager.Fetch(nc, r), servermanager.Fetch(opened, r)
        check(network_bytes(back) is not None and network_bytes(back) == network_bytes(mine)
              and list(back.GetExtent()) == list(mine.GetExtent()),
              "rank %d opened its own network from the .nvol, bit for bit, with its piece %s"
              % (r, list(back.GetExtent())))
    Delete(opened)


def check_global_figures(decoded, original, psnr, max_error, tolerance_db, against, max_error_scale=None):
    """The MPI tests' global figures against numpy over the assembled decoded field: NaN exactly where `original` (the
    serial field) is NaN, NeuralPSNR within `tolerance_db` of numpy's over the rest (peak: the range of `original`),
    NeuralMaxError numpy's within 1e-3 x max(1, max_error_scale; default the range). Returns (numpy PSNR, numpy max)."""
    import numpy as np
    inside = ~np.isnan(original)
    check(np.array_equal(np.isnan(decoded), ~inside), "the decoded regions are NaN exactly where %s is (%d samples; "
          "decoded NaN %d)" % (against, int(np.sum(~inside)), int(np.sum(np.isnan(decoded)))))
    span = float(original[inside].max() - original[inside].min())
    error = (decoded - original)[inside]
    numpy_psnr = 10.0 * math.log10(span ** 2 / float(np.mean(error ** 2)))
    numpy_max = float(np.abs(error).max())
    log("global PSNR %.3f dB (numpy %.3f), max error %.4f (numpy %.4f)" % (psnr, numpy_psnr, max_error, numpy_max))
    check(abs(psnr - numpy_psnr) <= tolerance_db, "NeuralPSNR %.3f dB is numpy's over the decoded regions against %s "
          "(%.3f dB) within %.2f dB" % (psnr, against, numpy_psnr, tolerance_db))
    scale = span if max_error_scale is None else max_error_scale(numpy_max)
    check(abs(max_error - numpy_max) <= 1e-3 * max(1.0, scale), "NeuralMaxError %.4f is numpy's %.4f"
          % (max_error, numpy_max))
    return numpy_psnr, numpy_max


def band_mask(extents, shape, whole, pixels):
    """The MPI tests' band along the piece boundaries in a picture with the planes z = const and y = const edge-on
    through its centre: pixels within `pixels` of the centre row (where the pieces split z) and of the centre column
    (where they split y), for pieces of point extents `extents` of the whole extent `whole`."""
    import numpy as np
    mask = np.zeros(shape[:2], dtype=bool)
    rows, cols = shape[0], shape[1]
    if any(e[5] < whole[5] for e in extents):
        mask[rows // 2 - pixels:rows // 2 + pixels + 1, :] = True
    if any(e[3] < whole[3] for e in extents):
        mask[:, cols // 2 - pixels:cols // 2 + pixels + 1] = True
    return mask


def grab_window(view, path):
    """The pixels the view's window holds now, without rendering (unlike a screenshot, which renders the final
    picture), written to `path`; returns them (rows, columns, 3)."""
    from vtkmodules.vtkIOImage import vtkPNGWriter
    from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter
    window = vtkWindowToImageFilter()
    window.SetInput(view.GetRenderWindow())
    window.ShouldRerenderOff()
    window.ReadFrontBufferOff()
    window.Update()
    writer = vtkPNGWriter()
    writer.SetFileName(path)
    writer.SetInputConnection(window.GetOutputPort())
    writer.Write()
    return read_png(path)


def drifting_series(folder, n, steps):
    """A vortex drifting along x over `steps` time steps (n^3 points, array "f"), written as a .pvd of .vti files in
    `folder`; returns the .pvd's path and the fields (z, y, x; float32 values as float64)."""
    import numpy as np
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter
    z, y, x = np.meshgrid(*(np.linspace(0.0, 1.0, n),) * 3, indexing="ij")
    entries, fields = [], []
    for t in range(steps):
        cx = 0.35 + 0.04 * t
        field = (np.sin(7 * (x - cx)) * np.cos(6 * y) +
                 0.8 * np.exp(-((x - cx) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) / 0.05) + 0.3 * np.sin(9 * z + 0.3 * t))
        fields.append(field.astype(np.float32).astype(np.float64))
        image = vtkImageData()
        image.SetDimensions(n, n, n)
        array = numpy_to_vtk(field.astype(np.float32).ravel(), deep=True)
        array.SetName("f")
        image.GetPointData().SetScalars(array)
        writer = vtkXMLImageDataWriter()
        name = "step_%d.vti" % t
        writer.SetFileName(os.path.join(folder, name))
        writer.SetInputData(image)
        writer.Write()
        entries.append('<DataSet timestep="%g" file="%s"/>' % (0.1 * t, name))
    pvd = os.path.join(folder, "series.pvd")
    with open(pvd, "w") as f:
        f.write('<?xml version="1.0"?><VTKFile type="Collection" version="0.1"><Collection>%s</Collection></VTKFile>'
                % "".join(entries))
    return pvd, fields
