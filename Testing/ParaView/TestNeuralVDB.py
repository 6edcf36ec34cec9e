"""OpenVDB in and out (built with OpenVDB): the two VDB files of the data folder open as images over their active
voxels with the grid's transform (half and double grids), survive a write -> read round trip exactly (the sparse
writer prunes only the background), train with Neural Compress, and the decoded field goes back out as a sparse
.vdb (background pruned with a tolerance) that reads back within that tolerance. Bad files and grid names give clear
errors. Registered only for builds with OpenVDB; skips without the data."""
import os
import sys

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

nvtest.finish()
