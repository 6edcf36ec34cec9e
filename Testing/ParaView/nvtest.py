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

SKIP = 125  # ctest SKIP_RETURN_CODE

_failures = []


def plugin_path():
    path = os.environ.get("NV_PLUGIN", "")
    if not path or not os.path.exists(path):
        log("NV_PLUGIN does not name the built plugin: %r" % path)
        _exit(2)
    return path


def load_plugin(namespace):
    from paraview.simple import LoadPlugin
    LoadPlugin(plugin_path(), remote=False, ns=namespace)


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


def compare_images(test_png, reference_png, threshold_db, label):
    """Check image PSNR >= threshold_db; writes an amplified difference image on failure."""
    import numpy as np
    a = read_png(test_png)
    b = read_png(reference_png)
    psnr = image_psnr(a, b)
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
