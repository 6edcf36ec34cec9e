"""Exports the two time series of ../shared/data as raw float32 volumes with .nhdr headers, for the engine's warm-start
benchmark (nvBenchOnline warm) on a GPU machine without ParaView:
  voreen_openlb_flow_timeseries: |physVelocity| on its 33x44x28 grid, all 34 steps;
  cth_spyplot_timeseries: cell field "Pressure (dynes/cm^2^)" of the AMR resampled to an R^3 image (ResampleToImage), 9 dumps.
Usage: pvpython export_timeseries.py <shared/data> <out folder> [R=80]"""
import os
import sys

import numpy as np
from paraview.simple import *  # noqa: F401,F403
from paraview import servermanager
from vtkmodules.util.numpy_support import vtk_to_numpy

data, out = sys.argv[1], sys.argv[2]
R = int(sys.argv[3]) if len(sys.argv) > 3 else 80
os.makedirs(out, exist_ok=True)


def write(name, values, dims):
    values = np.ascontiguousarray(values, dtype=np.float32)
    values.tofile(os.path.join(out, name + ".raw"))
    with open(os.path.join(out, name + ".nhdr"), "w") as f:
        f.write("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nendian: little\n"
                "data file: %s.raw\n" % (dims[0], dims[1], dims[2], name))


flow = PVDReader(FileName=os.path.join(data, "voreen_openlb_flow_timeseries", "flow_demo_A.pvd"))
mag = Calculator(Input=flow, Function="mag(physVelocity)", ResultArrayName="speed")
for k, t in enumerate(flow.TimestepValues):
    mag.UpdatePipeline(t)
    image = servermanager.Fetch(mag)
    dims = image.GetDimensions()
    write("flow_%02d" % k, vtk_to_numpy(image.GetPointData().GetArray("speed")), dims)
print("flow: %d steps of %r" % (len(flow.TimestepValues), dims))

cth = SpyPlotReader(FileName=os.path.join(data, "cth_spyplot_timeseries", "spcth.0"))
PRESSURE = "Pressure (dynes/cm^2^)"
cth.CellArrays = [PRESSURE]
resample = ResampleToImage(Input=cth, SamplingDimensions=[R, R, R])
for k, t in enumerate(cth.TimestepValues):
    resample.UpdatePipeline(t)
    image = servermanager.Fetch(resample)
    values = vtk_to_numpy(image.GetPointData().GetArray(PRESSURE))
    write("cth_%02d" % k, values, (R, R, R))
    print("cth t=%g: range %g .. %g" % (t, values.min(), values.max()))
