"""Neural Compress of composites and AMR under MPI without a gather (issue 23): `mpiexec -n 2` and `-n 4 pvbatch`.

Cases (each trained per rank, 300 steps, CPU):
- "multiblock": a vtkMultiBlockDataSet of two grids -- the Wavelet's lower half tetrahedralized (unstructured) and
  its upper half as a structured grid (Transform) -- through RedistributeDataSet (k-d pieces of both blocks) at
  SamplingDimensions 38^3 (planes that miss the cuts);
- "structured": the Wavelet as a structured grid, the pieces its source gives the ranks (no redistribution);
- "amr": ParaView's AMRGaussianPulseSource (overlapping AMR, 2 levels, a cell array, blanking of the refined coarse
  cells) with its blocks dealt round-robin to the ranks by a programmable filter (the source itself makes every block
  on every rank), at the automatic sampling dimensions (the finest level's spacing);
- "enzo" (when NV_DATA_DIR holds it): the Enzo AMR cosmology output (overlapping AMR, cell array Density) as its
  reader deals the blocks to the ranks, at 48^3;
- "cth" (when NV_DATA_DIR holds it): CTH's SpyPlot output (non-overlapping AMR, the four files of one run, cell array
  Pressure) as ParaView's SpyPlot reader deals the files to the ranks, at 40^3.
Rank 0 first runs the same pipelines in a serial pvbatch (this script with --serial-reference <folder>, a subprocess)
and checks:
- no gather: each rank's network was trained from its own piece (NeuralPieceSourceSamples is the count of the rank's
  own samples -- points not ghosts, or AMR cells not under a finer level -- and less than the whole input's);
- the ranks' regions partition the serial lattice, the global figures are the same on every rank and NeuralPSNR is
  numpy's over the decoded regions against the serial resampling (within 0.05 dB); the decoded regions are NaN
  exactly where the serial resampling is outside the input;
- the composited picture against the serial one >= 35 dB.
"""
import builtins
import json
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
SETTINGS = dict(Device="CPU", Seed=7, Deterministic=1, TrainingSteps=300, BatchSize=16384, Levels=8,
                FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2", Log2TableSize=14, Threads=1,
                PSNRInterval=0, TrainInBackground=0, OutputMode="Decoded, float32")
PICTURE_DB = 35.0
GLOBAL_PSNR_DB = 0.05
SIZE = [300, 300]
BACKGROUND = [0.32, 0.34, 0.43]
# Ghost flags that make a sample not the source's own: duplicate / hidden points; duplicate, hidden, refined cells.
GHOST_POINT = 1 | 2
GHOST_CELL = 1 | 32 | 8

# Keeps block k of the AMR on rank k mod N (the AMR readers' round-robin); the source makes all on every rank.
DEAL_BLOCKS = """
from vtkmodules.vtkParallelCore import vtkMultiProcessController
c = vtkMultiProcessController.GetGlobalController()
rank, ranks = (c.GetLocalProcessId(), c.GetNumberOfProcesses()) if c else (0, 1)
source = self.GetInputDataObject(0, 0)
out = self.GetOutputDataObject(0)
levels = source.GetNumberOfLevels()
out.Initialize(levels, [source.GetNumberOfDataSets(level) for level in range(levels)])
out.SetAMRInfo(source.GetAMRInfo())
k = 0
for level in range(levels):
    for i in range(source.GetNumberOfDataSets(level)):
        if k % ranks == rank:
            out.SetDataSet(level, i, source.GetDataSet(level, i))
        k += 1
"""

nvtest.load_plugin(globals(), scripted=False)
out_dir = nvtest.output_dir()


def multiblock(mpi):
    lower = Tetrahedralize(Input=Wavelet(WholeExtent=[0, 40, 0, 40, 0, 20]))
    upper = Transform(Input=Wavelet(WholeExtent=[0, 40, 0, 40, 20, 40]))
    upper.Transform.Translate = [0.0, 0.0, 0.0]
    group = GroupDatasets(Input=[lower, upper])
    return RedistributeDataSet(Input=group) if mpi else group


def structured(mpi):
    grid = Transform(Input=Wavelet(WholeExtent=[0, 40, 0, 40, 0, 40]))
    grid.Transform.Translate = [0.0, 0.0, 0.0]
    return grid


def amr(mpi):
    return ProgrammableFilter(Input=AMRGaussianPulseSource(), Script=DEAL_BLOCKS, OutputDataSetType="Same as Input")


ENZO = os.path.join(os.environ.get("NV_DATA_DIR", ""), "enzo_amr_moving7", "DD0010", "moving7_0010.hierarchy")


def enzo(mpi):
    reader = EnzoReader(FileNames=[ENZO])
    reader.CellArrayStatus = ["Density"]
    return reader


CTH = os.path.join(os.environ.get("NV_DATA_DIR", ""), "cth_spyplot_timeseries", "spcth.0")
CTH_PRESSURE = "Pressure (dynes/cm^2^)"


def cth(mpi):
    reader = OpenDataFile(CTH)  # ParaView's SpyPlot reader: the 4 files of one dump, dealt to the ranks
    reader.CellArrays = [CTH_PRESSURE]
    return reader


# name, source, array, settings, the camera's distance (1: the whole box in view)
CASES = (("multiblock", multiblock, ("POINTS", "RTData"), dict(SamplingDimensions=[38, 38, 38]), 1.0),
         ("structured", structured, ("POINTS", "RTData"), dict(SamplingDimensions=[38, 38, 38]), 1.0),
         ("amr", amr, ("CELLS", "Gaussian-Pulse"), dict(SamplingDimensions=[0, 0, 0]), 0.5))
if os.environ.get("NV_DATA_DIR") and os.path.exists(ENZO):
    CASES += (("enzo", enzo, ("CELLS", "Density"), dict(SamplingDimensions=[48, 48, 48]), 1.0),)
if os.environ.get("NV_DATA_DIR") and os.path.exists(CTH):
    CASES += (("cth", cth, ("CELLS", CTH_PRESSURE), dict(SamplingDimensions=[40, 40, 40]), 1.0),)
if os.environ.get("NV_CASES"):  # a comma-separated subset, to run one case while debugging
    CASES = tuple(case for case in CASES if case[0] in os.environ["NV_CASES"].split(","))


def leaves(data):
    if data.IsA("vtkDataSet"):
        return [data]
    out, it = [], data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        out.append(it.GetCurrentDataObject())
        it.GoToNextItem()
    return out


def own_samples(data, array):
    """The source's own samples of `array` (association, name) in a piece: ghosts and refined AMR cells left out."""
    cells = array[0] == "CELLS"
    total = 0
    for leaf in leaves(data):
        if not leaf.IsA("vtkDataSet"):  # (a fetched piece's placeholders of the other ranks' blocks)
            continue
        values = (leaf.GetCellData() if cells else leaf.GetPointData()).GetArray(array[1])
        if values is None or leaf.GetNumberOfCells() == 0:
            continue
        ghosts = leaf.GetCellGhostArray() if cells else leaf.GetPointGhostArray()
        if ghosts is None:
            total += values.GetNumberOfTuples()
        else:
            total += int(np.sum((vtk_to_numpy(ghosts) & (GHOST_CELL if cells else GHOST_POINT)) == 0))
    return total


# A non-overlapping AMR's blocks as a multiblock (Fetch cannot move a vtkNonOverlappingAMR from a rank).
AS_MULTIBLOCK = """
from vtkmodules.vtkCommonDataModel import vtkImageData
source, out = self.GetInputDataObject(0, 0), self.GetOutputDataObject(0)
it = source.NewIterator()
it.InitTraversal()
k = 0
while not it.IsDoneWithTraversal():
    block = vtkImageData()  # (a vtkUniformGrid comes back from a rank as an empty vtkDataObject)
    block.ShallowCopy(it.GetCurrentDataObject())
    out.SetBlock(k, block)
    k += 1
    it.GoToNextItem()
"""


def local_data(proxy, rank=None):
    """The proxy's data object: in serial the algorithm's own output (Fetch cannot reduce AMR), else rank's piece."""
    proxy.UpdatePipeline()
    if rank is None:
        return proxy.GetClientSideObject().GetOutputDataObject(0)
    if proxy.GetDataInformation().DataInformation.GetCompositeDataClassName() == "vtkNonOverlappingAMR":
        blocks = ProgrammableFilter(Input=proxy, Script=AS_MULTIBLOCK, OutputDataSetType="vtkMultiblockDataSet")
        data = servermanager.Fetch(blocks, rank)
        Delete(blocks)
        return data
    return servermanager.Fetch(proxy, rank)


def render(nc, array, bounds, value_range, distance, path):
    view = nvtest.render_view(SIZE, BACKGROUND)
    display = Show(nc, view)
    display.SetRepresentationType("Neural Volume")
    ColorBy(display, ("POINTS", array[1]))
    display.SetScalarBarVisibility(view, False)
    for tf in (GetColorTransferFunction(array[1]), GetOpacityTransferFunction(array[1])):
        tf.RescaleTransferFunction(value_range[0], value_range[1])
    centre = [(bounds[2 * a] + bounds[2 * a + 1]) / 2.0 for a in range(3)]
    size = builtins.max(bounds[2 * a + 1] - bounds[2 * a] for a in range(3))
    eye = [centre[0] + 2.7 * size * distance, centre[1] - 2.0 * size * distance, centre[2] + 3.7 * size * distance]
    nvtest.set_camera(view, eye, focal=centre)
    Render(view)
    nvtest.shot(view, path, SIZE)
    Delete(display)
    Delete(view)


def serial_reference(folder):
    result = {}
    for name, make, array, settings, distance in CASES:
        source = make(False)
        nc = NeuralCompress(Input=source, SelectInputScalars=list(array), **SETTINGS, **settings)
        nc.UpdatePipeline()
        data = servermanager.Fetch(nc)
        extent = list(nc.GetDataInformation().GetExtent())
        lattice = [extent[1] + 1, extent[3] + 1, extent[5] + 1]
        resampled = ResampleToImage(Input=source, SamplingDimensions=lattice, UseInputBounds=1)
        image = servermanager.Fetch(resampled)
        values = vtk_to_numpy(image.GetPointData().GetArray(array[1])).astype(np.float64)
        valid = vtk_to_numpy(image.GetPointData().GetArray("vtkValidPointMask")) != 0
        values[~valid] = np.nan
        np.save(os.path.join(folder, name + ".npy"), values.reshape(lattice[2], lattice[1], lattice[0]))
        bounds = list(image.GetBounds())
        value_range = [float(np.nanmin(values)), float(np.nanmax(values))]
        result[name] = dict(psnr=nvtest.field_value(data, "NeuralPSNR"),
                            resampled_psnr=nvtest.field_value(data, "NeuralResampledPSNR"),
                            samples=own_samples(local_data(source), array), lattice=lattice, bounds=bounds,
                            range=value_range)
        nc.OutputMode = "Network only"
        nc.UpdatePipeline()
        render(nc, array, bounds, value_range, distance, os.path.join(folder, name + "-serial.png"))
        Delete(nc)
    with open(os.path.join(folder, "serial.json"), "w") as f:
        json.dump(result, f)
    nvtest.log("serial reference: %s" % result)


def check_case(nc, source, ranks, name, array, reference):
    check, log = nvtest.check, nvtest.log
    original = np.load(os.path.join(out_dir, name + ".npy"))
    lattice = reference["lattice"]
    whole = [0, lattice[0] - 1, 0, lattice[1] - 1, 0, lattice[2] - 1]
    pieces, holders = [], 0
    for r in range(ranks):
        own = own_samples(local_data(source, r), array)
        piece = servermanager.Fetch(nc, r)
        trained = nvtest.field_value(piece, "NeuralPieceSourceSamples")
        log("rank %d: %d own samples of its piece; trained from %s (the whole input: %d)"
            % (r, own, trained, reference["samples"]))
        if piece.GetNumberOfPoints() == 0:
            check(own == 0, "rank %d holds no samples and no region" % r)
            continue
        holders += 1
        pieces.append(piece)
        check(trained == own and own < reference["samples"], "rank %d trained from its own piece only (%s samples; "
              "its piece %d, the whole input %d)" % (r, trained, own, reference["samples"]))
    decoded, extents, figures = nvtest.assemble_pieces(pieces, array[1], whole, original.shape)
    psnr, max_error, model_bytes, networks = figures
    check(networks == holders, "NeuralNetworks %s == %d ranks with samples" % (networks, holders))
    nvtest.check_global_figures(decoded, original, psnr, max_error, GLOBAL_PSNR_DB, "the serial resampling")
    log("model bytes %d; serial: %.3f dB at the source, %.3f dB on the lattice"
        % (model_bytes, reference["psnr"], reference["resampled_psnr"]))
    info = nc.GetDataInformation()
    check(list(info.GetExtent()) == whole, "data information: the serial lattice %s" % str(info.GetExtent()))


def mpi_run():
    global out_dir
    check, log = nvtest.check, nvtest.log
    ranks, out_dir, reference = nvtest.mpi_test_start(__file__, out_dir, "CompositeMPI")
    if reference is None:
        return
    for name, make, array, settings, distance in CASES:
        log("--- %s" % name)
        source = make(True)
        nc = NeuralCompress(Input=source, SelectInputScalars=list(array), **SETTINGS, **settings)
        started = time.time()
        with nvtest.captured_messages() as messages:
            nc.UpdatePipeline()
        log("%s, %d ranks: UpdatePipeline %.1f s" % (name, ranks, time.time() - started))
        check("ERROR" not in messages[0], "no error: %r" % messages[0][-400:])
        check_case(nc, source, ranks, name, array, reference[name])
        nc.OutputMode = "Network only"
        nc.UpdatePipeline()
        ref = reference[name]
        render(nc, array, ref["bounds"], ref["range"], distance, os.path.join(out_dir, name + "-mpi.png"))
        nvtest.compare_images(os.path.join(out_dir, name + "-mpi.png"), os.path.join(out_dir, name + "-serial.png"),
                              PICTURE_DB, "%s: %d-rank picture vs serial" % (name, ranks))
        Delete(nc)


if SERIAL:
    serial_reference(sys.argv[sys.argv.index("--serial-reference") + 1])
else:
    mpi_run()
nvtest.finish()
