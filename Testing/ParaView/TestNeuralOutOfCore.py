"""Issue 22, the way in that never loads the file: the Neural Out-of-Core Reader reads a header only and Neural
Compress trains from the file through the random block buffer within MemoryBudget (CPU engine).

  * every format (.nhdr, raw .nrrd, .bov, .vti with raw appended data) and type (uint8, int16, uint16, int32,
    float32, float64; big and little endian): the reader's output has the file's geometry and no samples, the
    network trains, and the exact PSNR streamed over the file (NeuralPSNR, NeuralPSNRExact 1) equals the PSNR that
    numpy computes from the same file and the same network decoded (through a saved .nvol) within 0.01 dB;
  * out of core under a MemoryBudget of 40% of the file against Neural Compress of the same data in memory: within
    the bound stated below;
  * the Neural Volume draws it (a picture with the volume in it, close to the in-memory network's picture);
  * pause (its figures labelled estimates, Measure Now makes them exact), resume, stop;
  * HDF5 contiguous (pread) and chunked (hyperslabs through the HDF5 library: plain 8^3 chunks and deflate +
    shuffle chunks that do not divide the dimensions) train and their streamed PSNR is numpy's;
  * bad files: truncated data, a header promising more than the file holds (also 8 PB), an unsupported type, a
    compressed .vti, a missing data file, a data file that cannot be read (a directory), a truncated HDF5 file, HDF5
    chunks in a filter the HDF5 library cannot decode (LZF) -- one error each, an empty output, no crash, the peak
    memory of the process within 32 MiB of before; chunks too large for the MemoryBudget -- one error from Neural
    Compress, then trained under a budget that holds them.
"""
import math
import os
import shutil
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkImageData  # noqa: E402
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log

FOLDER = os.path.join(nvtest.output_dir(), "outofcore")
shutil.rmtree(FOLDER, ignore_errors=True)
os.makedirs(FOLDER)

DIMS = (40, 36, 32)  # x, y, z: not a cube, so an axis mix-up shows
SPACING = (0.5, 0.75, 1.0)
ORIGIN = (-3.0, 2.0, 1.5)
FAST = dict(TrainingSteps=150, BatchSize=8192, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2,
            Log2TableSize=14, Threads=2, PSNRInterval=50, Device="CPU", TimeBudget=0, Seed=3)
NP_TYPES = {"uint8": np.uint8, "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "float32": np.float32,
            "float64": np.float64}


def field(type_name):
    """A smooth field with structure at several scales in (z, y, x) order, scaled into `type_name`."""
    z, y, x = np.meshgrid(np.linspace(0, 1, DIMS[2]), np.linspace(0, 1, DIMS[1]), np.linspace(0, 1, DIMS[0]),
                          indexing="ij")
    f = np.sin(6 * x) * np.cos(4 * y) + 0.5 * np.sin(11 * z + 3 * x) + 0.25 * np.cos(9 * y * z)  # -1.75 .. 1.75
    scale = {"uint8": (120, 127), "int16": (9000, -500), "uint16": (18000, 32000), "int32": (5.0e8, 1000),
             "float32": (1.0, 0.0), "float64": (1.0e3, -2.0)}[type_name]
    values = f * scale[0] + scale[1]
    if np.issubdtype(NP_TYPES[type_name], np.integer):
        values = np.rint(values)
    return values.astype(NP_TYPES[type_name])


def raw_bytes(values, big_endian):
    return values.astype(values.dtype.newbyteorder(">" if big_endian else "<")).tobytes()


NRRD_TYPE = {"uint8": "uchar", "int16": "short", "uint16": "ushort", "int32": "int", "float32": "float",
             "float64": "double"}
BOV_TYPE = {"uint8": "BYTE", "int16": "SHORT", "uint16": "USHORT", "int32": "INT", "float32": "FLOAT",
            "float64": "DOUBLE"}


def nrrd_header(type_name, big_endian, sizes=DIMS):
    return ("NRRD0004\ntype: %s\ndimension: 3\nsizes: %d %d %d\nspace dimension: 3\n"
            "space directions: (%g,0,0) (0,%g,0) (0,0,%g)\nspace origin: (%g,%g,%g)\nencoding: raw\nendian: %s\n"
            % ((NRRD_TYPE[type_name],) + tuple(sizes) + SPACING + ORIGIN + ("big" if big_endian else "little",)))


def write_nhdr(name, values, type_name, big_endian=False, sizes=DIMS, raw=None):
    with open(os.path.join(FOLDER, name + ".raw"), "wb") as f:
        f.write(raw_bytes(values, big_endian) if raw is None else raw)
    with open(os.path.join(FOLDER, name + ".nhdr"), "w") as f:
        f.write(nrrd_header(type_name, big_endian, sizes) + "data file: %s.raw\n" % name)
    return os.path.join(FOLDER, name + ".nhdr")


def write_nrrd(name, values, type_name, big_endian=False):
    path = os.path.join(FOLDER, name + ".nrrd")
    with open(path, "wb") as f:
        f.write((nrrd_header(type_name, big_endian) + "\n").encode())
        f.write(raw_bytes(values, big_endian))
    return path


def write_bov(name, values, type_name, big_endian=False):
    with open(os.path.join(FOLDER, name + ".data"), "wb") as f:
        f.write(raw_bytes(values, big_endian))
    size = [SPACING[a] * (DIMS[a] - 1) for a in range(3)]
    path = os.path.join(FOLDER, name + ".bov")
    with open(path, "w") as f:
        f.write("DATA_FILE: %s.data\nDATA_SIZE: %d %d %d\nDATA_FORMAT: %s\nVARIABLE: %s\nDATA_ENDIAN: %s\n"
                "CENTERING: nodal\nBRICK_ORIGIN: %g %g %g\nBRICK_SIZE: %g %g %g\n"
                % ((name,) + DIMS + (BOV_TYPE[type_name], name, "BIG" if big_endian else "LITTLE") + ORIGIN +
                   tuple(size)))
    return path


def write_vti(name, values, compressed=False):
    image = vtkImageData()
    image.SetDimensions(*DIMS)
    image.SetSpacing(*SPACING)
    image.SetOrigin(*ORIGIN)
    array = numpy_to_vtk(values.ravel(), deep=1)
    array.SetName(name)
    image.GetPointData().SetScalars(array)
    writer = vtkXMLImageDataWriter()
    writer.SetInputData(image)
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    if not compressed:
        writer.SetCompressorTypeToNone()
    path = os.path.join(FOLDER, name + ".vti")
    writer.SetFileName(path)
    writer.Write()
    return path


H5_WRITER = r"""
import sys, numpy as np, h5py
path, kind = sys.argv[1], sys.argv[2]
values = np.load(sys.argv[3])
with h5py.File(path, "w") as f:
    group = f.create_group("fields")
    dtype = values.dtype.newbyteorder(">") if kind.endswith("big") else values.dtype
    options = {"chunked-big": dict(chunks=(8, 8, 8)), "chunked": dict(chunks=(8, 8, 8)),
               "gzip": dict(chunks=(5, 12, 16), compression="gzip", shuffle=True),
               "lzf": dict(chunks=(8, 8, 8), compression="lzf"),
               "bigchunk": dict(chunks=values.shape, compression="gzip")}.get(kind, {})
    d = group.create_dataset("density", data=values.astype(dtype), **options)
    d.attrs["spacing"] = np.array(%r)
    d.attrs["origin"] = np.array(%r)
""" % (SPACING, ORIGIN)


def write_h5(name, values, kind):
    """An HDF5 file written by h5py in a process of its own (a second HDF5 library must not enter pvbatch's)."""
    import subprocess
    path = os.path.join(FOLDER, name + ".h5")
    np.save(os.path.join(FOLDER, name + ".npy"), values)
    result = subprocess.run(["/usr/bin/python3", "-c", H5_WRITER, path, kind, os.path.join(FOLDER, name + ".npy")],
                            capture_output=True, text=True)
    if result.returncode != 0:
        log("h5py cannot write %s: %s" % (name, result.stderr.strip()[-300:]))
        return None
    return path


def figure(data, name):
    array = data.GetFieldData().GetArray(name)
    return array.GetValue(0) if array is not None else None


def reference_psnr(nc, values, label):
    """PSNR of the network decoded on the file's grid (a saved .nvol read back as float32) against `values`, with
    the range normalisation the filter uses."""
    path = os.path.join(FOLDER, label + ".nvol")
    SaveData(path, proxy=nc)
    decoded_reader = NeuralVolumeReader(FileName=path, OutputMode="Decoded, float32")
    decoded_reader.UpdatePipeline()
    image = servermanager.Fetch(decoded_reader)
    decoded = vtk_to_numpy(image.GetPointData().GetScalars()).astype(np.float64)
    Delete(decoded_reader)
    source = values.ravel().astype(np.float64)
    lo, hi = source.min(), source.max()
    error = (decoded - source) / (hi - lo)
    return 10 * math.log10(1.0 / np.mean(error * error)), np.max(np.abs(decoded - source))


def refresh(nc):
    """A live refresh, as ParaView's live-source timer makes it in the GUI."""
    nc.SMProxy.GetClientSideObject().Modified()
    nc.SMProxy.MarkModified(nc.SMProxy)
    nc.UpdatePipeline()
    return servermanager.Fetch(nc)


def in_memory_psnr(values, dims, **params):
    """Neural Compress of the same values held in memory (a TrivialProducer), blocking."""
    image = vtkImageData()
    image.SetDimensions(*dims)
    array = numpy_to_vtk(values.ravel(), deep=1)
    array.SetName("inmemory")
    image.GetPointData().SetScalars(array)
    producer = TrivialProducer()
    producer.GetClientSideObject().SetOutput(image)
    memory = NeuralCompress(Input=producer, SelectInputScalars=["POINTS", "inmemory"], **dict(params, TrainInBackground=0))
    memory.UpdatePipeline()
    psnr = figure(servermanager.Fetch(memory), "NeuralPSNR")
    return psnr, memory, producer


def train(path, budget_mib=0.0, **extra):
    reader = NeuralOutOfCoreReader(FileName=path)
    params = dict(FAST, TrainInBackground=0, MemoryBudget=budget_mib)
    params.update(extra)
    nc = NeuralCompress(Input=reader, **params)
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
        out = servermanager.Fetch(nc)
    return reader, nc, out, messages[0]


# --- the reader alone: geometry, no samples -------------------------------------------------------------------
values32 = field("float32")
path = write_nhdr("geometry", values32, "float32")
reader = NeuralOutOfCoreReader(FileName=path)
reader.UpdatePipeline()
image = servermanager.Fetch(reader)
check(image.GetDimensions() == DIMS, "reader: dimensions %s" % (image.GetDimensions(),))
check(np.allclose(image.GetSpacing(), SPACING) and np.allclose(image.GetOrigin(), ORIGIN),
      "reader: spacing %s origin %s" % (image.GetSpacing(), image.GetOrigin()))
check(image.GetPointData().GetNumberOfArrays() == 0, "reader: no samples are loaded")
probe_filter = NeuralCompress(Input=reader)
check(list(probe_filter.SelectInputScalars)[-1] == "geometry",
      "Neural Compress's array selection shows the file's field (%s)" % list(probe_filter.SelectInputScalars))
Delete(probe_filter)
reader.UpdatePropertyInformation()
log("reader: " + reader.GetProperty("FileSummary").GetElement(0))
Delete(reader)

# --- every format and type: trains, and the streamed exact PSNR is numpy's ----------------------------------------
CASES = [("nhdr", t, t in ("int16", "float64")) for t in NP_TYPES] + \
        [("nrrd", "uint16", True), ("nrrd", "float32", False), ("bov", "int16", True), ("bov", "float64", False),
         ("vti", "float32", False), ("vti", "uint8", False)]
# HDF5: contiguous (a raw block, pread), chunked (hyperslabs through the HDF5 library; chunks of 8^3, and deflate +
# shuffle chunks that do not divide the dimensions).
HDF5_CASES = [("h5", "uint16", True, "big"), ("h5", "float32", False, "little"), ("h5", "int16", True, "chunked-big"),
              ("h5", "float32", False, "gzip")]
written = {}
for fmt, type_name, big, *h5_kind in [c + ("",) for c in CASES] + HDF5_CASES:
    label = "%s_%s_%s%s" % (fmt, type_name, "be" if big else "le", "_" + h5_kind[0] if fmt == "h5" else "")
    values = field(type_name)
    writer = {"nhdr": write_nhdr, "nrrd": write_nrrd, "bov": write_bov}.get(fmt)
    if fmt == "h5":
        path = write_h5(label, values, h5_kind[0])
        if path is None:
            log("%s: not run (no h5py to write the file)" % label)
            continue
    else:
        path = writer(label, values, type_name, big) if writer else write_vti(label, values)
    written[fmt] = path
    reader, nc, out, text = train(path, TrainingSteps=FAST["TrainingSteps"] if label == "nhdr_float32_le" else 60)
    psnr, exact = figure(out, "NeuralPSNR"), figure(out, "NeuralPSNRExact")
    check("ERROR" not in text, "%s: no error (%s)" % (label, text.strip()[:300]))
    if psnr is None:
        check(False, "%s: no NeuralPSNR" % label)
        continue
    expected, max_error = reference_psnr(nc, values, label)
    log("%s: %.3f dB streamed (exact %s), numpy %.3f dB, max error %.4g (numpy %.4g)"
        % (label, psnr, exact, expected, figure(out, "NeuralMaxError"), max_error))
    check(exact == 1, "%s: the final figures are exact" % label)
    check(psnr > 20.0, "%s: the network learned the field (%.2f dB)" % (label, psnr))
    check(abs(psnr - expected) < 0.01, "%s: streamed PSNR %.4f vs numpy %.4f" % (label, psnr, expected))
    check(abs(figure(out, "NeuralMaxError") - max_error) <= 1e-3 * (values.max() - values.min()),
          "%s: max error" % label)
    if label == "nhdr_float32_le":
        # The whole file resident (the automatic budget holds it): the training of the same field in memory.
        memory_psnr, memory, producer = in_memory_psnr(values, DIMS, **FAST)
        log("fully resident: %.3f dB out of core, %.3f dB in memory" % (psnr, memory_psnr))
        check(psnr > memory_psnr - 1.5, "fully resident: at most 1.5 dB below in memory (%.2f vs %.2f)"
              % (psnr, memory_psnr))
        Delete(memory)
        Delete(producer)
    Delete(nc)
    Delete(reader)

# --- File, Open: the reader is offered for each format, beside ParaView's own reader where it has one -------------
factory = servermanager.vtkSMProxyManager.GetProxyManager().GetReaderFactory()
for extension, path in sorted(written.items()):
    readers = factory.GetReaders(path, servermanager.ActiveConnection.Session)
    names = [readers.GetString(i) for i in range(readers.GetNumberOfStrings())]
    log(".%s: File, Open offers %s" % (extension, names[1::3]))
    check("ZNeuralOutOfCoreReader" in names, ".%s: File, Open offers the out-of-core reader" % extension)
    if extension in ("nhdr", "vti"):
        # ParaView's own reader stays the default of scripts (OpenDataFile loads the field as before)
        opened = OpenDataFile(path)
        check(opened.GetXMLName() != "ZNeuralOutOfCoreReader",
              ".%s: OpenDataFile picks ParaView's reader (%s)" % (extension, opened.GetXMLName()))
        Delete(opened)

# --- out of core under a small budget against the same training in memory ------------------------------------------
BIG = (64, 64, 64)
z, y, x = np.meshgrid(*(np.linspace(0, 1, n) for n in BIG[::-1]), indexing="ij")
big = (np.sin(7 * x) * np.cos(5 * y) + 0.5 * np.sin(13 * z + 3 * x) + 0.3 * np.cos(11 * x * y)).astype(np.float32)
with open(os.path.join(FOLDER, "budget.raw"), "wb") as f:
    f.write(big.tobytes())
with open(os.path.join(FOLDER, "budget.nhdr"), "w") as f:
    f.write("NRRD0004\ntype: float\ndimension: 3\nsizes: 64 64 64\nencoding: raw\nendian: little\n"
            "data file: budget.raw\n")
budget_mib = 0.4 * big.nbytes / 2 ** 20
LONG = dict(TrainingSteps=1500, Levels=12, FeaturesPerLevel=2, Log2TableSize=15, NetworkWidth=32, HiddenLayers=2)
reader, nc, out, text = train(os.path.join(FOLDER, "budget.nhdr"), budget_mib, **LONG)
ooc_psnr = figure(out, "NeuralPSNR")
log("out of core, MemoryBudget %.3f MiB (40%% of the file): %.3f dB; %s" % (budget_mib, ooc_psnr, text.strip()[-400:]))
# A decoded output that the budget cannot hold is refused (the network stays), never made by loading the field.
with nvtest.captured_messages() as messages:
    nc.OutputMode = "Decoded, float32"
    nc.UpdatePipeline()
    refused = servermanager.Fetch(nc)
check("exceeds its memory budget" in messages[0], "a decoded output above the budget is refused: %r"
      % messages[0][-300:])
check(refused.GetPointData().GetNumberOfArrays() == 0 and figure(refused, "NeuralSteps") == LONG["TrainingSteps"],
      "the network stays without a decoded field or a new training")
nc.OutputMode = "Network only"
nc.UpdatePipeline()
memory_psnr, memory, producer = in_memory_psnr(big, BIG, **dict(FAST, **LONG))
log("in memory: %.3f dB; out of core %.3f dB (gap %.3f dB)" % (memory_psnr, ooc_psnr, memory_psnr - ooc_psnr))
# A partly resident field (1418 resident 2^3-cell blocks, up to 240 replaced a step; the rest of the budget for the
# probe and the slabs): a step's 8192 samples fall into 1418 blocks, about 6 to a block, and train like a smaller
# batch (vtkNeuralOutOfCoreInput.cxx, BlockShapeFor: a budget this small gets 2^3-cell cubes). Measured (2 cores):
# 53.2 dB against 59.8 dB in memory after 1500 steps (6.6 dB below; 54.2 dB while the buffer's bookkeeping, ~80 bytes a
# 108-byte block, was not counted in the budget; 52.9 dB before the block size followed the batch). A budget that holds
# a 128 x 2 x 2-cell brick a sample trains close to memory (nv.pv.NeuralOutOfCoreLarge).
check(ooc_psnr > memory_psnr - 7.0, "out of core within 7 dB of in memory (%.2f vs %.2f)" % (ooc_psnr, memory_psnr))
# The automatic network of an out-of-core input keeps its training memory within an eighth of the MemoryBudget (a
# network sized for the ratio alone can hold more than the budget itself: 14 GB beside 8 GiB on the H100's 41 GB file).
reader_auto, nc_auto, out_auto, text_auto = train(os.path.join(FOLDER, "budget.nhdr"), budget_mib,
                                                  **dict(LONG, TrainingSteps=50, Log2TableSize=0))
log("automatic size out of core: " + text_auto.strip()[-300:])
check("within an eighth of the MemoryBudget" in text_auto and "automatic table 2^10 (2^" in text_auto,
      "the automatic table is fitted to the MemoryBudget: %r" % text_auto[-300:])
unfitted = NeuralCompress(Input=producer, SelectInputScalars=["POINTS", "inmemory"],
                          **dict(FAST, **dict(LONG, TrainingSteps=50, Log2TableSize=0, TrainInBackground=0)))
with nvtest.captured_messages() as messages:
    unfitted.UpdatePipeline()
check("within an eighth" not in messages[0] and "2^10 table" not in messages[0],
      "in memory the automatic size is the ratio's: %r" % messages[0][-200:])
# BypassPageCache: the block buffer reads the disk itself (O_DIRECT); the output says what the buffer read (the bytes
# its blocks hold, whole pages taken from the file). The values read are the engine's bit for bit (engine.BlockBuffer).
reader_direct, nc_direct, out_direct, text_direct = train(os.path.join(FOLDER, "budget.nhdr"), budget_mib,
                                                          **dict(LONG, TrainingSteps=50, BypassPageCache=1))
read_direct = figure(out_direct, "NeuralBufferBytesRead")
taken_direct = figure(out_direct, "NeuralBufferBytesTransferred")
fill_direct = figure(out_direct, "NeuralBufferFirstFillBytes")
log("BypassPageCache: %s bytes of blocks read (first fill %s), %s taken from the file, %s swaps missed" % (
    read_direct, fill_direct, taken_direct, figure(out_direct, "NeuralBufferSwapsMissed")))
check("ERROR" not in text_direct and figure(out_direct, "NeuralSteps") == 50, "BypassPageCache trains: %r"
      % text_direct[-300:])
check(read_direct is not None and fill_direct is not None and read_direct > fill_direct > 0 and
      taken_direct >= read_direct, "the buffer's reads are reported, whole pages with O_DIRECT (%s, %s, %s)" % (
          read_direct, fill_direct, taken_direct))
# Through the page cache a block's rows of a z-slice are one read of their span (VolumeFileReader kSliceSpanBytes): the
# bytes taken are more than the blocks hold, at most (2 x 64 + 3) / (3 x 3) times (three rows of a 64-wide file, blocks
# at least 3 samples wide).
taken, read = figure(out, "NeuralBufferBytesTransferred"), figure(out, "NeuralBufferBytesRead")
check(read is not None and taken is not None and read < taken <= read * 131 / 9,
      "through the page cache a slice's rows are read at once (%s bytes taken for %s read)" % (taken, read))
Delete(nc_direct)
Delete(reader_direct)
for proxy in (nc_auto, reader_auto, unfitted):
    Delete(proxy)

# --- the Neural Volume draws it ---------------------------------------------------------------------------------
if os.environ.get("DISPLAY"):
    def picture(source, name):
        view = CreateView("RenderView")
        view.ViewSize = [240, 240]
        view.Background = [0, 0, 0]
        view.OrientationAxesVisibility = 0
        rep = Show(source, view)
        check(rep.Representation == "Neural Volume", "%s drawn as Neural Volume (%s)" % (name, rep.Representation))
        ResetCamera(view)
        Render(view)
        png = os.path.join(FOLDER, name + ".png")
        SaveScreenshot(png, view, ImageResolution=[240, 240])
        from vtkmodules.vtkIOImage import vtkPNGReader
        r = vtkPNGReader()
        r.SetFileName(png)
        r.Update()
        pixels = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).astype(np.float64)
        Delete(view)
        return pixels[:, :3]
    ooc_picture = picture(nc, "outofcore")
    memory_picture = picture(memory, "inmemory")
    background = ooc_picture[0]  # a corner: the view's background
    covered = np.mean(np.abs(ooc_picture - background).max(axis=1) > 10)
    difference = np.mean(np.abs(ooc_picture - memory_picture))
    log("picture: %.1f%% of the pixels show the volume; mean difference to the in-memory network's %.2f / 255"
        % (100 * covered, difference))
    check(covered > 0.1, "the Neural Volume shows the volume (%.3f of the pixels)" % covered)
    check(difference < 12.0, "the picture is close to the in-memory network's (%.2f)" % difference)
else:
    log("no DISPLAY: the picture is not drawn")
Delete(memory)
Delete(producer)

# --- background training: pause, Measure Now, resume, stop ---------------------------------------------------------
Delete(nc)
nc = NeuralCompress(Input=reader, **dict(FAST, **dict(LONG, TrainingSteps=100000, TrainInBackground=1,
                                                      MemoryBudget=budget_mib)))
nc.UpdatePipeline()
deadline = time.time() + 60
while time.time() < deadline:
    time.sleep(0.5)
    out = refresh(nc)
    if (figure(out, "NeuralSteps") or 0) > 150:
        break
nc.PauseTraining()
time.sleep(0.5)
nc.UpdatePipeline()
out = servermanager.Fetch(nc)
state = out.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0)
check(state == "Paused", "paused (state %s)" % state)
check(figure(out, "NeuralPSNRExact") == 0, "while training the PSNR is an estimate")
estimate = figure(out, "NeuralPSNR")
nc.MeasureNow()
nc.UpdatePipeline()
out = servermanager.Fetch(nc)
log("paused at %d steps: estimate %.3f dB, measured over the file %.3f dB"
    % (figure(out, "NeuralSteps"), estimate, figure(out, "NeuralPSNR")))
check(figure(out, "NeuralPSNRExact") == 1, "Measure Now: the figures are exact")
check(abs(figure(out, "NeuralPSNR") - estimate) < 3.0, "the estimate is near the exact figure")
paused_steps = figure(out, "NeuralSteps")
time.sleep(1.0)
out = refresh(nc)
check(figure(out, "NeuralSteps") == paused_steps, "no step while paused")
check(figure(out, "NeuralPSNRExact") == 1, "paused: the measured figures stay")
nc.ResumeTraining()
time.sleep(2.0)
out = refresh(nc)
check(figure(out, "NeuralSteps") > paused_steps, "resumed (%d > %d steps)" % (figure(out, "NeuralSteps"), paused_steps))
check(figure(out, "NeuralPSNRExact") == 0, "resumed: the PSNR is an estimate again")
nc.StopTraining()
nc.WaitForTraining()
nc.UpdatePipeline()
out = servermanager.Fetch(nc)
state = out.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0)
check(state == "Stopped", "stopped (state %s)" % state)
check(figure(out, "NeuralPSNRExact") == 1, "stopped: the figures are measured over the file")
Delete(nc)
Delete(reader)

# A new reader's file trained in the background and refreshed as the GUI's live timer does, the reader executing again
# meanwhile: the same file, so no new preparation. Before OutOfCoreStamp the output object's modification time stood for
# the file and every refresh prepared the file again on a background thread (a value-range pass and a block buffer's
# first fill, logged on stderr; the GUI: 31 in 40 s, 13 steps). The filter's log lines are counted on fd 2.
z, y, x = np.meshgrid(*(np.linspace(0, 1, 160),) * 3, indexing="ij")
((np.sin(9 * x) * np.cos(7 * y) + 0.5 * np.sin(11 * z + 2 * x)).astype(np.float32)).tofile(
    os.path.join(FOLDER, "gui160.raw"))
with open(os.path.join(FOLDER, "gui160.nhdr"), "w") as f:
    f.write("NRRD0004\ntype: float\ndimension: 3\nsizes: 160 160 160\nencoding: raw\nendian: little\n"
            "data file: gui160.raw\n")
reader = NeuralOutOfCoreReader(FileName=os.path.join(FOLDER, "gui160.nhdr"))
nc = NeuralCompress(Input=reader, MemoryBudget=4, TrainingSteps=100000, TrainInBackground=1, OutputMode="Network only",
                    Device="CPU")
nc.UpdatePipeline()
deadline = time.time() + 60
out = refresh(nc)
while figure(out, "NeuralSteps") is None and time.time() < deadline:  # its first network published
    time.sleep(0.5)
    out = refresh(nc)
with nvtest.captured_stderr() as logged:
    for k in range(6):
        time.sleep(0.5)
        if k % 2:
            reader.SMProxy.GetClientSideObject().Modified()
            reader.UpdatePipeline()
        out = refresh(nc)
    time.sleep(1.0)  # (a preparation runs on a background thread)
passes = logged[0].count("value-range pass started")
state = out.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0)
check(state == "Training" and passes == 0,
      "refreshes and the reader executing again do not prepare the file again (%s; %d value-range passes)" % (
          state, passes))
nc.StopTraining()
nc.WaitForTraining()
Delete(nc)
Delete(reader)

# --- the GPU (host-sampled batches from the block buffer), where one is usable --------------------------------------
nc = NeuralCompress(Input=NeuralOutOfCoreReader(FileName=os.path.join(FOLDER, "budget.nhdr")),
                    **dict(FAST, **dict(LONG, Device="Auto", TrainInBackground=0, MemoryBudget=budget_mib)))
nc.UpdatePropertyInformation()
if nc.GetProperty("GPUUsable") is not None and nc.GetProperty("GPUUsable").GetElement(0) == 1:
    nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    device = out.GetFieldData().GetAbstractArray("NeuralDevice").GetValue(0)
    log("GPU (%s): %.3f dB out of core under the same budget (CPU %.3f dB)" % (device, figure(out, "NeuralPSNR"),
                                                                                ooc_psnr))
    check("CPU" not in device and figure(out, "NeuralPSNRExact") == 1, "trained on the GPU, exact figures")
    check(figure(out, "NeuralPSNR") > ooc_psnr - 3.0, "the GPU's network is as good as the CPU's")
else:
    log("no usable GPU: the GPU case is not run")
Delete(nc)

# --- bad files: one error each, an empty output, no crash, nothing allocated beyond the budget ------------------------
def status_kib(name):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(name + ":"))


values16 = field("uint16")
good = raw_bytes(values16, False)
BAD = [
    ("truncated data file", write_nhdr("truncated", values16, "uint16", raw=good[:len(good) // 2]),
     "the file is truncated or the header is wrong"),
    ("header promising more samples", write_nhdr("lying", values16, "uint16", sizes=(40, 36, 64), raw=good),
     "the header promises"),
    ("header promising 8 PB", write_nhdr("huge", values16, "uint16", sizes=(1000000, 1000000, 4000), raw=good),
     "the header promises"),
    ("unsupported type", write_nhdr("int64", values16, "uint16"), "cannot be streamed"),
    # A sparse 17.6 GB file (no disk used) of more samples than a network states: refused at its header, at once.
    ("more than 2^34 samples", write_nhdr("toomany", values16, "uint8", sizes=(2600, 2600, 2600), raw=b""),
     "a model states at most"),
    ("compressed .vti", write_vti("compressed", values16, compressed=True), "compressed"),
    ("missing data file", write_nhdr("missing", values16, "uint16"), "cannot open"),
    ("unreadable data file (a directory)", write_nhdr("directory", values16, "uint16"), "is not a regular file"),
]
# The unsupported type: the header says int64 (the engine streams uint8 .. float64 only).
with open(BAD[3][1], "w") as f:
    f.write(nrrd_header("uint16", False).replace("type: ushort", "type: int64") + "data file: int64.raw\n")
os.truncate(os.path.join(FOLDER, "toomany.raw"), 2600 ** 3)
os.remove(os.path.join(FOLDER, "missing.raw"))
os.remove(os.path.join(FOLDER, "directory.raw"))
os.makedirs(os.path.join(FOLDER, "directory.raw"))
contiguous = write_h5("bad_truncated", values16, "little")
if contiguous:
    with open(contiguous, "r+b") as f:
        f.truncate(os.path.getsize(contiguous) // 2)
    BAD.append(("truncated HDF5 file", contiguous, "truncated"))
lzf = write_h5("bad_lzf", values16, "lzf")
if lzf:
    BAD.append(("HDF5 chunks in a filter this HDF5 cannot decode (LZF)", lzf, "cannot decode"))
for label, path, phrase in BAD:
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # VmHWM from here
    before = status_kib("VmRSS")
    with nvtest.captured_messages() as messages:
        reader = NeuralOutOfCoreReader(FileName=path)
        reader.UpdatePipeline()
        image = servermanager.Fetch(reader)
        nc = NeuralCompress(Input=reader, **dict(FAST, TrainInBackground=0, MemoryBudget=16))
        nc.UpdatePipeline()
    grown = (status_kib("VmHWM") - before) / 1024.0
    text = messages[0]
    log("%s: %s (peak +%.1f MiB)" % (label, text.strip().replace("\n", " | ")[:400], grown))
    check(phrase in text, "%s: the error says %r" % (label, phrase))
    check(text.count("Neural Out Of Core Reader:") == 1, "%s: one reader error (%d)"
          % (label, text.count("Neural Out Of Core Reader:")))
    check(image.GetNumberOfPoints() == 0, "%s: empty output" % label)
    check(servermanager.Fetch(nc).GetFieldData().GetArray("NeuralNetwork") is None, "%s: no network" % label)
    check(grown < 32.0, "%s: nothing allocated beyond the budget (peak +%.1f MiB)" % (label, grown))
    Delete(nc)
    Delete(reader)

# A chunk layout the budget cannot stream: one chunk of the whole dataset, deflated, under a MemoryBudget of 0.25 MiB
# (an eighth of it for decoded chunks): Neural Compress refuses it with the figures (the reader reads its header).
whole = write_h5("bad_bigchunk", values16, "bigchunk")
if whole:
    reader = NeuralOutOfCoreReader(FileName=whole)
    with nvtest.captured_messages() as messages:
        nc = NeuralCompress(Input=reader, **dict(FAST, TrainInBackground=0, MemoryBudget=0.25))
        nc.UpdatePipeline()
    text = messages[0]
    log("one 40x36x32 chunk under 0.25 MiB: %s" % text.strip().replace("\n", " | ")[:400])
    check("a chunk layout this budget cannot stream" in text and text.count("ERROR") == 1,
          "chunks too large for the budget: one error (%r)" % text[-300:])
    check(servermanager.Fetch(nc).GetFieldData().GetArray("NeuralNetwork") is None, "big chunks: no network")
    nc.MemoryBudget = 8  # the same file streams under a budget that holds the chunk's decoding
    nc.UpdatePipeline()
    check(figure(servermanager.Fetch(nc), "NeuralPSNR") is not None, "big chunks under 8 MiB: trained")
    Delete(nc)
    Delete(reader)

nvtest.finish()
