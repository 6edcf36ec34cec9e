"""OpenVDB in and out (built with OpenVDB): the two VDB files of the data folder open as images over their active
voxels with the grid's transform (half and double grids), survive a write -> read round trip exactly (the sparse
writer prunes only the background), train with Neural Compress, and the decoded field goes back out as a sparse
.vdb (background pruned with a tolerance) that reads back within that tolerance. The sparse output ("Active voxels")
holds exactly the dense image's active voxels: values, positions, index coordinates and the grid's metadata. Bad
files and grid names give clear errors. Registered only for builds with OpenVDB; skips without the data."""
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log
data_dir = os.environ.get("NV_DATA_DIR", "")
SMOKE = os.path.join(data_dir, "openvdb_smoke1", "smoke.vdb")
DENSE = os.path.join(data_dir, "openvdb_smoke_dense_double", "smoke.vdb")
check("OpenVDBReader" in globals(), "the plugin has the OpenVDB reader")
if not (os.path.exists(SMOKE) and os.path.exists(DENSE)):
    nvtest.skip("OpenVDB files not found under NV_DATA_DIR=%r" % data_dir)
out_dir = nvtest.output_dir()


def load(path, **props):
    with nvtest.captured_messages() as messages:
        reader = OpenVDBReader(FileName=[path], **props)
        reader.UpdatePipeline()
        image = servermanager.Fetch(reader)
    reader.UpdatePropertyInformation()
    return reader, image, messages[0]


def active(reader):
    reader.UpdatePropertyInformation()
    return int(reader.GetPropertyValue("ActiveVoxels"))


def values(image):
    a = image.GetPointData().GetScalars()
    dims = image.GetDimensions()
    return vtk_to_numpy(a).reshape(dims[2], dims[1], dims[0]), a


def write(proxy, path, **props):
    with nvtest.captured_messages() as messages:
        SaveData(path, proxy=proxy, **props)
    return messages[0]


SPARSE, DENSE_TYPE = "Active voxels (sparse)", "Image (dense)"


def load_sparse(path, **props):
    """The reader's own output in sparse mode (pvbatch runs built-in: the client-side object is the reader);
    also the seconds from creating the proxy (which reads the grid) to the end of RequestData."""
    with nvtest.captured_messages() as messages:
        t0 = time.time()
        reader = OpenVDBReader(FileName=[path], OutputType=SPARSE, **props)
        reader.UpdatePipeline()
        seconds = time.time() - t0
    return reader, reader.GetClientSideObject().GetOutputDataObject(0), messages[0], seconds


def dense_seconds(path):
    t0 = time.time()
    reader = OpenVDBReader(FileName=[path])
    reader.UpdatePipeline()
    seconds = time.time() - t0
    Delete(reader)
    return seconds


def check_sparse(label, path, dense_reader, image):
    """The sparse output of `path` against its dense image: the same voxels, values, positions and transform."""
    dense_time = dense_seconds(path)
    reader, poly, text, sparse_time = load_sparse(path)
    log("%s sparse: read in %.3f s (dense %.3f s), %s points" % (label, sparse_time, dense_time,
        poly.GetNumberOfPoints() if poly else None))
    check("ERROR" not in text, "%s sparse: reads without an error (%s)" % (label, text.strip()[-200:]))
    if not check(poly is not None and poly.IsA("vtkPolyData"), "%s sparse: a polydata (%s)"
                 % (label, poly.GetClassName() if poly else None)):
        return
    n = poly.GetNumberOfPoints()
    check(n == active(reader) == active(dense_reader) and n > 0, "%s sparse: one point per active voxel (%d, %d, %d)"
          % (label, n, active(reader), active(dense_reader)))
    verts = poly.GetVerts()
    check(poly.GetNumberOfCells() == n and verts.GetNumberOfCells() == n
          and np.array_equal(vtk_to_numpy(verts.GetOffsetsArray()), np.arange(n + 1))
          and np.array_equal(vtk_to_numpy(verts.GetConnectivityArray()), np.arange(n))
          and poly.GetCellType(0) == 1 and poly.GetCellType(n - 1) == 1,
          "%s sparse: one vertex cell per point, nothing else" % label)
    V, dense_array = poly.GetPointData().GetScalars(), image.GetPointData().GetScalars()
    C = poly.GetPointData().GetArray("VDBCoordinate")
    if not check(V is not None and V.GetName() == dense_array.GetName() and V.GetDataType() == dense_array.GetDataType()
                 and V.GetNumberOfTuples() == n and V.GetNumberOfComponents() == 1,
                 "%s sparse: the active scalars are the dense array's name and type (%s %s)"
                 % (label, V.GetName() if V else None, V.GetDataTypeAsString() if V else None)):
        return
    if not check(C is not None and C.GetDataTypeAsString() == "int" and C.GetNumberOfComponents() == 3
                 and C.GetNumberOfTuples() == n, "%s sparse: an int 3-component 'VDBCoordinate' array" % label):
        return
    fd = poly.GetFieldData()
    for name, cls, size in (("VDBBackground", "vtkDoubleArray", 1), ("VDBIndexBox", "vtkIntArray", 6),
                            ("VDBIndexToWorld", "vtkDoubleArray", 16), ("VDBGridName", "vtkStringArray", 1)):
        a = fd.GetAbstractArray(name)
        if not check(a is not None and a.GetClassName() == cls and a.GetNumberOfValues() == size,
                     "%s sparse: field data '%s' is a %s of %d values (%s)" % (label, name, cls, size,
                     (a.GetClassName(), a.GetNumberOfValues()) if a is not None else None)):
            return
    check(fd.GetAbstractArray("VDBGridName").GetValue(0) == dense_array.GetName(),
          "%s sparse: VDBGridName '%s'" % (label, fd.GetAbstractArray("VDBGridName").GetValue(0)))

    # The index box: the dense image's extent, and the active voxels' bounding box.
    box = [fd.GetAbstractArray("VDBIndexBox").GetValue(i) for i in range(6)]
    lo, hi = np.array(box[0::2]), np.array(box[1::2])
    ext, dims = image.GetExtent(), image.GetDimensions()
    check(list(ext[0::2]) == [0, 0, 0] and list(hi - lo) == [ext[1], ext[3], ext[5]],
          "%s sparse: VDBIndexBox %s matches the dense extent %s" % (label, box, ext))
    ijk = vtk_to_numpy(C).astype(np.int64)
    check(np.array_equal(ijk.min(0), lo) and np.array_equal(ijk.max(0), hi),
          "%s sparse: VDBIndexBox is the active voxels' bounding box (%s %s)" % (label, ijk.min(0), ijk.max(0)))
    rel = ijk - lo
    flat = rel[:, 0] + dims[0] * (rel[:, 1] + dims[1] * rel[:, 2])
    check(len(np.unique(flat)) == n, "%s sparse: every voxel once" % label)

    # The values: exactly the dense image's at the same voxels.
    A, _ = values(image)
    S = vtk_to_numpy(V)
    check(np.array_equal(A[rel[:, 2], rel[:, 1], rel[:, 0]], S), "%s sparse: the values equal the dense image's exactly"
          % label)

    # The positions: the dense image's points (origin + direction * spacing * ijk; a sample through VTK itself).
    P = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
    Dm = image.GetDirectionMatrix()
    D = np.array([[Dm.GetElement(r, c) for c in range(3)] for r in range(3)])
    W = np.asarray(image.GetOrigin()) + (rel * np.asarray(image.GetSpacing())) @ D.T
    b = image.GetBounds()
    size = float(np.linalg.norm([b[1] - b[0], b[3] - b[2], b[5] - b[4]]))
    err = float(np.abs(W - P).max())
    sample = np.linspace(0, n - 1, 257).astype(np.int64)
    err_vtk = max(float(np.abs(np.asarray(image.GetPoint(int(flat[s]))) - P[s]).max()) for s in sample)
    check(err <= 1e-6 * size and err_vtk <= 1e-6 * size, "%s sparse: the points are the dense image's points "
          "(max error %.3g, through vtkImageData::GetPoint %.3g; size %.4g)" % (label, err, err_vtk, size))

    # VDBIndexToWorld: (i, j, k, 1) -> the sparse points; the box's minimum -> the dense origin.
    M = np.array([fd.GetAbstractArray("VDBIndexToWorld").GetValue(i) for i in range(16)]).reshape(4, 4)
    H = np.c_[ijk, np.ones(n)] @ M.T
    o = M @ np.r_[lo, 1.0]
    check(np.array_equal(M[3], [0.0, 0.0, 0.0, 1.0]) and float(np.abs(H[:, :3] - P).max()) <= 1e-9 * size
          and float(np.abs(o[:3] - np.asarray(image.GetOrigin())).max()) <= 1e-9 * size,
          "%s sparse: VDBIndexToWorld maps the coordinates to the points and the box minimum to the origin (%s)"
          % (label, M.tolist()))

    # The background: what the dense image holds at the voxels that are not active.
    bg = fd.GetAbstractArray("VDBBackground").GetValue(0)
    on = np.zeros(A.shape, bool)
    on[rel[:, 2], rel[:, 1], rel[:, 0]] = True
    off = np.argwhere(~on)
    if len(off):
        k, j, i = off[0]
        check(float(A[k, j, i]) == bg and bool(np.all(A[~on] == bg)), "%s sparse: VDBBackground %r is the dense value "
              "at the inactive voxel %s (and at all %d inactive ones)" % (label, bg, (i, j, k), len(off)))
    else:
        log("%s sparse: every voxel of the box is active; VDBBackground %r" % (label, bg))
        check(n == A.size and np.isfinite(bg), "%s sparse: no inactive voxel in the box, so all %d are points"
              % (label, A.size))

    # Deterministic order; switching the output type back and forth on one proxy.
    again, poly2, _, _ = load_sparse(path)
    check(poly2.GetNumberOfPoints() == n and np.array_equal(
          vtk_to_numpy(poly2.GetPointData().GetArray("VDBCoordinate")), vtk_to_numpy(C)),
          "%s sparse: the same order on a second read" % label)
    Delete(again)
    reader.OutputType = DENSE_TYPE
    reader.UpdatePipeline()
    img = reader.GetClientSideObject().GetOutputDataObject(0)
    check(img.IsA("vtkImageData") and img.GetDimensions() == dims and active(reader) == n,
          "%s: switched to the dense output (%s)" % (label, img.GetClassName()))
    reader.OutputType = SPARSE
    reader.UpdatePipeline()
    poly3 = reader.GetClientSideObject().GetOutputDataObject(0)
    check(poly3.IsA("vtkPolyData") and poly3.GetNumberOfPoints() == n, "%s: and back to the sparse one" % label)
    Delete(reader)


# 1. The half-float smoke: 111 x 222 x 112 active bounding box from index (1, 2, 1), voxel size 0.47619.
smoke, image, text = load(SMOKE)
A, array = values(image)
log("smoke1: dims %s origin %s spacing %s type %s range %s active %s" % (image.GetDimensions(), image.GetOrigin(),
    image.GetSpacing(), array.GetDataTypeAsString(), array.GetRange(), active(smoke)))
check("ERROR" not in text, "smoke1 reads without an error (%s)" % text.strip()[-200:])
check(image.GetDimensions() == (111, 222, 112), "smoke1: the active bounding box (%s)" % (image.GetDimensions(),))
check(all(abs(s - 0.47619) < 1e-4 for s in image.GetSpacing()), "smoke1: the voxel size as spacing")
check(active(smoke) == 1049275, "smoke1: 1,049,275 active voxels (%s)" % active(smoke))
check(array.GetDataTypeAsString() == "float" and array.GetName() == "density", "smoke1: a float 'density' array")
check_sparse("smoke1", SMOKE, smoke, image)

# 2. Write -> read: the same values where the re-read box lies, background outside it.
path = os.path.join(out_dir, "smoke_roundtrip.vdb")
text = write(smoke, path)
again, image2, text2 = load(path)
B, _ = values(image2)
shift = [(o2 - o1) / s for o1, o2, s in zip(image.GetOrigin(), image2.GetOrigin(), image.GetSpacing())]
off = [int(round(x)) for x in shift]
check(all(abs(x - k) < 1e-6 for x, k in zip(shift, off)) and image2.GetSpacing() == image.GetSpacing(),
      "round trip: the transform (the grid's translation and voxel size) comes back (%s)" % shift)
d2 = image2.GetDimensions()
sub = A[off[2]:off[2] + d2[2], off[1]:off[1] + d2[1], off[0]:off[0] + d2[0]]
outside = A.copy()
outside[off[2]:off[2] + d2[2], off[1]:off[1] + d2[1], off[0]:off[0] + d2[0]] = 0
check(sub.shape == B.shape and np.array_equal(sub, B) and not outside.any(),
      "round trip: identical values (box %s at %s), background elsewhere" % (d2, off))
check(active(again) <= active(smoke) and active(again) == int(np.count_nonzero(A)),
      "round trip: the non-background voxels are the active ones (%s)" % active(again))

# 3. The dense double grid: train, decode, write sparse with a tolerance, read back within it.
dense, dimage, text = load(DENSE)
check(dimage.GetDimensions() == (128, 64, 64) and active(dense) == 524288, "dense double: 128 x 64 x 64 active "
      "(%s, %s)" % (dimage.GetDimensions(), active(dense)))
check(dimage.GetPointData().GetScalars().GetDataTypeAsString() == "double", "dense double: a double array")
check_sparse("dense double", DENSE, dense, dimage)
nc = NeuralCompress(Input=dense, SelectInputScalars=["POINTS", "density"], TrainingSteps=300, BatchSize=16384,
                    Log2TableSize=14, Device="CPU", Threads=2, Deterministic=1, TrainInBackground=0,
                    OutputMode="Decoded, float32")
nc.UpdatePipeline()
decoded = servermanager.Fetch(nc)
psnr = decoded.GetFieldData().GetArray("NeuralPSNR").GetValue(0)
check(psnr > 35.0, "dense double: Neural Compress PSNR > 35 dB (%.2f)" % psnr)
D, _ = values(decoded)
lo, hi = dimage.GetPointData().GetScalars().GetRange()
tol = 0.01 * (hi - lo)
vdb = os.path.join(out_dir, "decoded_sparse.vdb")
text = write(nc, vdb, Tolerance=tol)
back, bimage, text = load(vdb)
C, _ = values(bimage)
off = [int(round((o2 - o1) / s)) for o1, o2, s in zip(decoded.GetOrigin(), bimage.GetOrigin(), decoded.GetSpacing())]
d2 = bimage.GetDimensions()
full = np.zeros_like(D)
full[off[2]:off[2] + d2[2], off[1]:off[1] + d2[1], off[0]:off[0] + d2[0]] = C
err = float(np.abs(full - D).max())
raw = D.size * 4
log("decoded sparse: %d of %d voxels active, %d bytes (dense float32 %d), max |error| %.4g (tolerance %.4g)"
    % (active(back), D.size, os.path.getsize(vdb), raw, err, tol))
check(err <= tol * 1.0001, "the sparse .vdb reads back within the tolerance (%.4g <= %.4g)" % (err, tol))
check(active(back) < D.size, "the background is pruned (%d of %d active)" % (active(back), D.size))

# 4. Bad input: not a VDB, a grid that does not exist.
bad = os.path.join(out_dir, "not_a.vdb")
with open(bad, "wb") as f:
    f.write(b"this is not an OpenVDB file at all")
r, img, text = load(bad)
check("OpenVDB reader" in text and "ERROR" in text and img.GetNumberOfPoints() == 0, "not a VDB: a clear error (%s)"
      % text.strip()[-160:])
r, img, text = load(SMOKE, GridName="temperature")
check("no grid 'temperature'" in text and "density" in text and img.GetNumberOfPoints() == 0,
      "unknown grid: the error lists the grids (%s)" % text.strip()[-160:])
r, poly, text, _ = load_sparse(bad)
check("OpenVDB reader" in text and "ERROR" in text and poly.GetNumberOfPoints() == 0, "not a VDB, sparse: a clear error "
      "(%s)" % text.strip()[-160:])
r, poly, text, _ = load_sparse(SMOKE, GridName="temperature")
check("no grid 'temperature'" in text and poly.IsA("vtkPolyData") and poly.GetNumberOfPoints() == 0,
      "unknown grid, sparse: the same error, an empty polydata (%s)" % text.strip()[-160:])

# 5. Neural Compress on the sparse output of smoke1 trains from the active voxels and background samples without a
#    dense grid: the output covers the same box as the dense reader's image, its figures are measured at the bank's
#    samples, and the decoded field matches the dense grid over every voxel (numpy, independently of the filter).
#    Measured on the CPU engine (Deterministic, 2 threads, 150 steps): 39.2 dB at the samples, 40.2 dB over all voxels.
sparse = OpenVDBReader(FileName=[SMOKE], OutputType=SPARSE)
dense_ref = servermanager.Fetch(OpenVDBReader(FileName=[SMOKE]))
with nvtest.captured_messages() as messages:
    ncs = NeuralCompress(Input=sparse, SelectInputScalars=["POINTS", "density"], TrainingSteps=150, BatchSize=32768,
                         Device="CPU", Threads=2, Deterministic=1, Log2TableSize=16, OutputMode="Decoded, float32")
    ncs.UpdatePipeline()
    sout = servermanager.Fetch(ncs)
text = messages[0]
log("sparse smoke1: " + text.strip()[-400:])
check("sparse OpenVDB grid, 1049275 active of 2759904 voxels" in text and "ERROR" not in text,
      "sparse smoke1: trained from the active voxels (%s)" % text.strip()[-300:])
check(sout.GetDimensions() == dense_ref.GetDimensions() and
      np.allclose(sout.GetBounds(), dense_ref.GetBounds(), atol=1e-6 * 100),
      "sparse smoke1: the output covers the dense image's box (%s %s vs %s %s)"
      % (sout.GetDimensions(), sout.GetBounds(), dense_ref.GetDimensions(), dense_ref.GetBounds()))
ref = vtk_to_numpy(dense_ref.GetPointData().GetArray("density")).astype(np.float64)
dec = vtk_to_numpy(sout.GetPointData().GetArray("density")).astype(np.float64)
span = ref.max() - ref.min()
psnr_all = 10 * np.log10(1.0 / np.mean(((dec - ref) / span) ** 2)) if dec.shape == ref.shape else float("nan")
psnr_samples = nvtest.field_value(sout, "NeuralPSNR")
log("sparse smoke1: PSNR %s dB at %s samples, %.2f dB over all %d voxels (numpy)"
    % (psnr_samples, nvtest.field_value(sout, "NeuralSourceSamples"), psnr_all, ref.size))
check(np.isfinite(psnr_all) and psnr_all > 39.0, "sparse smoke1: PSNR over every voxel > 39 dB (%.2f)" % psnr_all)
check(psnr_samples is not None and 38.0 < psnr_samples < psnr_all + 3.0,
      "sparse smoke1: the reported PSNR is measured, not flattering (%s vs %.2f over all voxels)"
      % (psnr_samples, psnr_all))
# The VDB structure: macrocells (8 voxels a side) without an active voxel -- nor one starting the next cell -- are
# the background exactly, in the decoded output as in every render path (nv::SourceInfo::occupancy).
coords = vtk_to_numpy(servermanager.Fetch(sparse).GetPointData().GetArray("VDBCoordinate")).astype(np.int64)
box = vtk_to_numpy(servermanager.Fetch(sparse).GetFieldData().GetArray("VDBIndexBox")).reshape(3, 2)
dims = np.array(sout.GetDimensions())
ncell = np.maximum(1, (dims - 1 + 7) // 8)
occupied = np.zeros(ncell[::-1], bool)
local = coords - box[:, 0]
for dz in (0, 1):
    for dy in (0, 1):
        for dx in (0, 1):
            shift = np.array([dx, dy, dz])
            c = local // 8 - shift * (local % 8 == 0)
            ok = (shift == 0) | (local % 8 == 0)
            keep = ok.all(axis=1) & (c >= 0).all(axis=1)
            c = np.minimum(c[keep], ncell - 1)
            occupied[c[:, 2], c[:, 1], c[:, 0]] = True
# The cell of each decoded voxel as the engine computes it (float32: u = i / (n - 1), cell = floor(u * (n - 1) / 8)).
grid = [np.minimum((np.float32(np.arange(n) / max(n - 1, 1)) * np.float32((n - 1) / 8.0)).astype(np.int64), m - 1)
        for n, m in zip(dims, ncell)]
cz, cy, cx = np.meshgrid(grid[2], grid[1], grid[0], indexing="ij")
empty = ~occupied[cz, cy, cx].ravel()
background = servermanager.Fetch(sparse).GetFieldData().GetArray("VDBBackground").GetValue(0)
log("sparse smoke1: %d of %d voxels in empty macrocells (%d of %d cells occupied)"
    % (empty.sum(), empty.size, occupied.sum(), occupied.size))
check(empty.sum() > 0 and (dec[empty] == background).all(),
      "sparse smoke1: every decoded voxel of an empty macrocell is the background exactly (%d voxels)" % empty.sum())
ncs.UpdatePropertyInformation()
steps = ncs.GetPropertyValue("TotalStepsTrained")
check(steps == 150, "sparse smoke1: 150 steps trained (%s)" % steps)
ncs.OutputMode = "Network only"
ncs.UpdatePipeline()
ncs.UpdatePropertyInformation()
check(ncs.GetPropertyValue("TotalStepsTrained") == steps, "sparse smoke1: an output-mode change trains nothing")

nvtest.finish()
