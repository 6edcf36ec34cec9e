"""Any-dataset benchmark, CPU side (pvbatch on the 2-core machine): for each real dataset that is not an image,
  - the sampling throughput of VTK on the CPU: Resample (vtkResampleToImage onto the automatic image and onto 128^3)
    and Probe (vtkProbeFilter at 10^6 random points of the bounding box, with the default locator and with the
    vtkStaticCellLocator that Neural Compress's Sampling Probe uses), in targets per second;
  - the filter with Sampling Probe (its bank of 2^20 probed points) at the same steps, and the bank itself exported
    for the GPU run (nvBench curve --bank): <name>.bank.f32 (x y z in network coordinates, value; float32);
  - the Neural Compress filter on the CPU engine (Resample, automatic dimensions, 2^14 table, batch 16384,
    Deterministic, 2 threads): PSNR at the source's own points / cells after 1000 steps, and the time;
  - exports for the GPU run (nvBench curve --points): the resampled fields (NaN outside the domain) as .nhdr + raw
    float32, and the source samples (network coordinates + values) as raw float32 / float64.
Prints RESULT lines. Usage: pvbatch anydataset_bench.py <plugin.so> <shared/data> <out folder> [steps=1000] [names]
[scale: SamplingDimensions = scale x the automatic ones, exported as <name>_x<scale>]"""
import json
import os
import sys
import time

import numpy as np
from paraview.simple import *  # noqa: F401,F403
from paraview import servermanager
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import vtkPolyData
from vtkmodules.vtkFiltersCore import vtkProbeFilter, vtkResampleToImage, vtkCompositeDataProbeFilter
from vtkmodules.vtkFiltersGeneral import vtkPassSelectedArrays

plugin, data, out = sys.argv[1], sys.argv[2], sys.argv[3]
steps = int(sys.argv[4]) if len(sys.argv) > 4 else 1000
only = sys.argv[5].split(",") if len(sys.argv) > 5 else None
scale = int(sys.argv[6]) if len(sys.argv) > 6 else 1  # SamplingDimensions = scale x the automatic ones
LoadPlugin(plugin, remote=False, ns=globals())
os.makedirs(out, exist_ok=True)
D = data + "/"


def cases():
    disk = ExodusIIReader(FileName=D + "disk_out_ref/disk_out_ref.ex2")
    disk.PointVariables = ["Temp"]
    yield "disk_out_ref", disk, ("POINTS", "Temp"), None
    mug = ExodusIIReader(FileName=D + "mug_moose/mug.e")
    mug.PointVariables = ["convected"]
    yield "mug_t10", mug, ("POINTS", "convected"), mug.TimestepValues[10]
    enzo = EnzoReader(FileNames=[D + "enzo_amr_moving7/DD0010/moving7_0010.hierarchy"])
    enzo.CellArrayStatus = ["Density"]
    yield "enzo_amr", enzo, ("CELLS", "Density"), None
    cth = SpyPlotReader(FileName=D + "cth_spyplot_timeseries/spcth_a.0")
    cth.CellArrays = ["Pressure (dynes/cm^2^)"]
    yield "cth_amr", cth, ("CELLS", "Pressure (dynes/cm^2^)"), cth.TimestepValues[-1]


def source_object(proxy, t):
    proxy.UpdatePipeline(t) if t is not None else proxy.UpdatePipeline()
    return proxy.GetClientSideObject().GetOutputDataObject(0)


def resample_rate(obj, assoc, name, dims):
    sel = vtkPassSelectedArrays()
    sel.SetInputDataObject(obj)
    sel.GetArraySelection(0 if assoc == "POINTS" else 1).EnableArray(name)
    r = vtkResampleToImage()
    r.SetInputConnection(sel.GetOutputPort())
    r.SetUseInputBounds(True)
    r.SetSamplingDimensions(*dims)
    t0 = time.time()
    r.Update()
    s = time.time() - t0
    return r.GetOutput(), s, dims[0] * dims[1] * dims[2] / s


def probe_rate(obj, n=1000000, static=False):
    b = [0.0] * 6
    if obj.IsA("vtkDataSet"):
        b = obj.GetBounds()
    else:
        obj.GetBounds(b)
    rng = np.random.default_rng(1)
    xyz = np.stack([rng.uniform(b[2 * a], b[2 * a + 1], n) for a in range(3)], axis=1)
    pts = vtkPoints()
    from vtkmodules.util.numpy_support import numpy_to_vtk
    pts.SetData(numpy_to_vtk(xyz, deep=True))
    pd = vtkPolyData()
    pd.SetPoints(pts)
    p = vtkCompositeDataProbeFilter() if not obj.IsA("vtkDataSet") else vtkProbeFilter()
    if static:
        from vtkmodules.vtkCommonDataModel import vtkStaticCellLocator
        p.SetCellLocatorPrototype(vtkStaticCellLocator())
    p.SetInputData(pd)
    p.SetSourceData(obj)
    t0 = time.time()
    p.Update()
    s = time.time() - t0
    valid = vtk_to_numpy(p.GetOutput().GetPointData().GetArray(p.GetValidPointMaskArrayName())).mean()
    return s, n / s, valid


for name, proxy, (assoc, array), t in cases():
    if only and name not in only:
        continue
    obj = source_object(proxy, t)
    # Neural Compress on the CPU engine (automatic resampling).
    if scale > 1:
        auto = NeuralCompress(Input=proxy, SelectInputScalars=[assoc, array], TrainingSteps=1, Device="CPU",
                              TrainInBackground=0)
        auto.UpdatePipeline(t) if t is not None else auto.UpdatePipeline()
        fine = [scale * d - (scale - 1) for d in servermanager.Fetch(auto).GetDimensions()]
        Delete(auto)
        name = "%s_x%d" % (name, scale)
    t0 = time.time()
    nc = NeuralCompress(Input=proxy, SelectInputScalars=[assoc, array], TrainingSteps=steps, BatchSize=16384,
                        SamplingDimensions=fine if scale > 1 else [0, 0, 0],
                        Device="CPU", Threads=2, Deterministic=1, Log2TableSize=14, TrainInBackground=0,
                        OutputMode="Decoded, float32", PSNRInterval=0)
    nc.UpdatePipeline(t) if t is not None else nc.UpdatePipeline()
    wall = time.time() - t0
    o = servermanager.Fetch(nc)
    fd = o.GetFieldData()
    dims = o.GetDimensions()
    psnr = fd.GetArray("NeuralPSNR").GetValue(0)
    grid_psnr = fd.GetArray("NeuralResampledPSNR").GetValue(0)
    secs = fd.GetArray("NeuralTrainingSeconds").GetValue(0)
    n_src = int(fd.GetArray("NeuralSourceSamples").GetValue(0))
    # Sampling throughput: Resample at the automatic dimensions and at 128^3, Probe at 10^6 random points.
    img, rs, rrate = resample_rate(obj, assoc, array, list(dims))
    _, rs128, rrate128 = resample_rate(obj, assoc, array, [128, 128, 128])
    ps, prate, pvalid = probe_rate(obj)
    pss, psrate, _ = probe_rate(obj, static=True)
    # Sampling Probe: the same filter settings with the bank; the bank exported the way the filter builds it.
    t0 = time.time()
    ncp = NeuralCompress(Input=proxy, SelectInputScalars=[assoc, array], TrainingSteps=steps, BatchSize=16384,
                         Sampling="Probe", Device="CPU", Threads=2, Deterministic=1, Log2TableSize=14,
                         TrainInBackground=0, PSNRInterval=0)
    ncp.UpdatePipeline(t) if t is not None else ncp.UpdatePipeline()
    probe_wall = time.time() - t0
    probe_psnr = servermanager.Fetch(ncp).GetFieldData().GetArray("NeuralPSNR").GetValue(0)
    Delete(ncp)
    # Exports for the GPU run: the resampled field (NaN outside) and the source samples in network coordinates.
    values = vtk_to_numpy(img.GetPointData().GetArray(array)).astype(np.float32).copy()
    mask = vtk_to_numpy(img.GetPointData().GetArray("vtkValidPointMask"))
    values[mask == 0] = np.nan
    values.tofile(os.path.join(out, name + ".raw"))
    with open(os.path.join(out, name + ".nhdr"), "w") as f:
        f.write("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nendian: little\n"
                "data file: %s.raw\n" % (dims[0], dims[1], dims[2], name))
    ib = img.GetBounds()
    leaves = []
    if obj.IsA("vtkDataSet"):
        leaves = [obj]
    else:
        it = obj.NewIterator()
        it.InitTraversal()
        while not it.IsDoneWithTraversal():
            leaves.append(it.GetCurrentDataObject())
            it.GoToNextItem()
    xyz, val = [], []
    from vtkmodules.vtkFiltersCore import vtkCellCenters
    for leaf in leaves:
        if assoc == "POINTS":
            a = leaf.GetPointData().GetArray(array)
            if a is None:
                continue
            p = vtk_to_numpy(leaf.GetPoints().GetData()) if leaf.GetPoints() is not None else None
            if p is None:
                p = np.array([leaf.GetPoint(i) for i in range(leaf.GetNumberOfPoints())])
            v = vtk_to_numpy(a)
            keep = np.ones(len(v), bool)
        else:
            a = leaf.GetCellData().GetArray(array)
            if a is None:
                continue
            if leaf.IsA("vtkImageData"):
                # cell centres of an AMR block, all of them (vtkCellCenters leaves blanked cells out)
                e, o, h = leaf.GetExtent(), leaf.GetOrigin(), leaf.GetSpacing()
                ax = [o[k] + h[k] * (np.arange(e[2 * k], max(e[2 * k + 1], e[2 * k] + 1)) + 0.5) for k in range(3)]
                zz, yy, xx = np.meshgrid(ax[2], ax[1], ax[0], indexing="ij")
                p = np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1)
            else:
                cc = vtkCellCenters()
                cc.SetInputData(leaf)
                cc.Update()
                p = vtk_to_numpy(cc.GetOutput().GetPoints().GetData())
            v = vtk_to_numpy(a)
            g = leaf.GetCellData().GetArray("vtkGhostType")
            keep = np.ones(len(v), bool) if g is None else (vtk_to_numpy(g) & (1 | 8 | 32)) == 0
        xyz.append(p[keep])
        val.append(v[keep] if v.ndim == 1 else np.linalg.norm(v[keep], axis=1))
    xyz, val = np.concatenate(xyz), np.concatenate(val).astype(np.float64)
    u = np.stack([(xyz[:, k] - ib[2 * k]) / max(ib[2 * k + 1] - ib[2 * k], 1e-30) for k in range(3)], axis=1)
    np.clip(u, 0, 1).astype(np.float32).tofile(os.path.join(out, name + ".points.f32"))
    val.tofile(os.path.join(out, name + ".values.f64"))
    # The bank: 2^20 uniform random points of the image's box probed inside the source's cells (static locator).
    rng = np.random.default_rng(1)
    nb = 1 << 20
    ub = rng.random((nb, 3))
    wb = np.stack([ib[2 * k] + ub[:, k] * (ib[2 * k + 1] - ib[2 * k]) for k in range(3)], axis=1)
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkStaticCellLocator
    bp = vtkPoints()
    bp.SetData(numpy_to_vtk(wb, deep=True))
    bpd = vtkPolyData()
    bpd.SetPoints(bp)
    sel = vtkPassSelectedArrays()
    sel.SetInputDataObject(obj)
    sel.GetArraySelection(0 if assoc == "POINTS" else 1).EnableArray(array)
    prb = vtkCompositeDataProbeFilter()
    prb.SetInputData(bpd)
    prb.SetSourceConnection(sel.GetOutputPort())
    prb.SetCellLocatorPrototype(vtkStaticCellLocator())
    prb.Update()
    bv = vtk_to_numpy(prb.GetOutput().GetPointData().GetArray(array))
    bv = bv if bv.ndim == 1 else np.linalg.norm(bv, axis=1)
    bm = vtk_to_numpy(prb.GetOutput().GetPointData().GetArray(prb.GetValidPointMaskArrayName())) != 0
    bm &= np.isfinite(bv)
    np.concatenate([ub[bm], bv[bm, None]], axis=1).astype(np.float32).tofile(os.path.join(out, name + ".bank.f32"))
    print("RESULT " + json.dumps(dict(
        what="anydataset", name=name, input=obj.GetClassName(), source_samples=n_src, exported_samples=int(len(val)),
        dims=list(dims), outside_fraction=float((mask == 0).mean()), cpu_steps=steps, cpu_train_s=round(secs, 2),
        cpu_filter_wall_s=round(wall, 2), psnr_source=round(psnr, 2), psnr_resampled=round(grid_psnr, 2),
        resample_s=round(rs, 3), resample_targets_per_s=int(rrate), resample128_s=round(rs128, 3),
        resample128_targets_per_s=int(rrate128), probe_s=round(ps, 3), probe_targets_per_s=int(prate),
        probe_valid_fraction=round(float(pvalid), 3), probe_static_s=round(pss, 3),
        probe_static_targets_per_s=int(psrate), cpu_probe_psnr_source=round(probe_psnr, 2),
        cpu_probe_filter_wall_s=round(probe_wall, 2), bank_points=int(bm.sum()))), flush=True)
