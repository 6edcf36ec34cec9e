"""Particles on the GPU machine (issue 26): N particles (default 10 M) drawn from a Gaussian density truncated to a
ball, values from an analytic function, trained by Neural Compress with Sampling Probe (the bank of random points,
each evaluated by the engine's kernel reconstruction), against an image of the same function at the particles'
automatic resolution trained with the same network and table (TimeBudget 0: both run all their steps). Prints
RESULT lines and writes (JSON):
  - preparation: the locator's build, the reconstruction at the image's samples and the Probe bank's build (wall
    seconds, from the filter's description), the bank's size, and the process's peak resident memory after each run;
  - steps/s of both trainings (NeuralSteps / NeuralTrainingSeconds) and their ratio (the issue asks >= 50%);
  - PSNR over time of both (the filter's log table: step, elapsed seconds, PSNR) and the final figures (PSNR and max
    error at the particles, ratio against positions + scalar).

    pvbatch --force-offscreen-rendering particles_bench.py PLUGIN OUT_JSON [--n 10000000] [--steps 3000]
            [--device CUDA] [--log2-table 19] [--probe-points 16777216] [--only particles|image]
            [--psnr-interval N]
    (--device CPU --n 200000 --steps 300 --log2-table 16 --probe-points 1048576: a quick run on the CPU machine;
     --only particles --steps 2: the preparation's time and peak memory alone)"""
import argparse
import json
import re
import sys
import time

import numpy as np
from paraview.simple import *  # noqa: F401,F403
from paraview import servermanager
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkPoints, vtkStringOutputWindow, vtkOutputWindow
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPolyData

parser = argparse.ArgumentParser()
parser.add_argument("plugin")
parser.add_argument("out")
parser.add_argument("--n", type=int, default=10_000_000)
parser.add_argument("--steps", type=int, default=3000)
parser.add_argument("--device", default="CUDA")
parser.add_argument("--log2-table", type=int, default=19)
parser.add_argument("--probe-points", type=int, default=1 << 24)
parser.add_argument("--batch", type=int, default=1 << 18)
parser.add_argument("--only", choices=("particles", "image"), help="train one of the two (default: both)")
parser.add_argument("--psnr-interval", type=int, default=None,
                    help="steps between PSNR estimates (default steps / 30; their time counts in the step rate)")
args = parser.parse_args()
LoadPlugin(args.plugin, remote=False, ns=globals())
COMMON = dict(TrainInBackground=0, Device=args.device, TrainingSteps=args.steps, BatchSize=args.batch, TimeBudget=0,
              Log2TableSize=args.log2_table, OutputMode="Network only",
              PSNRInterval=max(1, args.steps // 30) if args.psnr_interval is None else args.psnr_interval)


def analytic(x, y, z):
    return np.sin(4.0 * x) * np.cos(3.0 * y) + 0.5 * z


def particle_set(n):
    rng = np.random.default_rng(7)
    chunks, have = [], 0
    while have < n:
        p = rng.normal(0.5, 0.18, (n, 3))
        p = p[np.linalg.norm(p - 0.5, axis=1) < 0.45]
        chunks.append(p)
        have += len(p)
    p = np.concatenate(chunks)[:n]
    pd = vtkPolyData()
    pts = vtkPoints()
    pts.SetData(numpy_to_vtk(p, deep=True))
    pd.SetPoints(pts)
    a = numpy_to_vtk(analytic(p[:, 0], p[:, 1], p[:, 2]).astype(np.float32), deep=True)
    a.SetName("f")
    pd.GetPointData().AddArray(a)
    return pd


def image_of(dims, bounds):
    axes = [np.linspace(bounds[2 * a], bounds[2 * a + 1], dims[a]) for a in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    im = vtkImageData()
    im.SetDimensions(dims)
    im.SetOrigin(bounds[0], bounds[2], bounds[4])
    im.SetSpacing([(bounds[2 * a + 1] - bounds[2 * a]) / (dims[a] - 1) for a in range(3)])
    a = numpy_to_vtk(analytic(x, y, z).astype(np.float32).ravel(), deep=True)
    a.SetName("f")
    im.GetPointData().AddArray(a)
    return im


def memory_mib():
    """(resident, peak resident) of this process in MiB, from /proc/self/status."""
    values = {}
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(("VmRSS:", "VmHWM:")):
                values[line.split(":")[0]] = int(line.split()[1]) / 1024.0
    return values.get("VmRSS", 0.0), values.get("VmHWM", 0.0)


def reset_peak():
    """Restarts the kernel's peak-resident count (VmHWM) from the current size (Linux >= 4.0)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def train(dataset, **extra):
    src = PVTrivialProducer()
    src.GetClientSideObject().SetOutput(dataset)
    catcher = vtkStringOutputWindow()
    previous = vtkOutputWindow.GetInstance()
    previous.Register(None)
    vtkOutputWindow.SetInstance(catcher)
    base_mib = memory_mib()[0]
    reset_peak()
    t0 = time.time()
    nc = NeuralCompress(Input=src, SelectInputScalars=["POINTS", "f"], **dict(COMMON, **extra))
    nc.UpdatePipeline()
    wall = time.time() - t0
    vtkOutputWindow.SetInstance(previous)
    previous.UnRegister(None)
    out = servermanager.Fetch(nc)
    log = servermanager.Fetch(nc, idx=1)
    fd = out.GetFieldData()

    def value(name):
        a = fd.GetArray(name)
        return a.GetValue(0) if a else None
    columns = {c: vtk_to_numpy(log.GetColumnByName(c)) for c in ("Step", "ElapsedSeconds", "PSNR")
               if log.GetColumnByName(c) is not None}
    measured = np.isfinite(columns["PSNR"]) if "PSNR" in columns else slice(None)
    curve = {c: v[measured].tolist() for c, v in columns.items()}  # the steps where the PSNR was measured
    r = dict(wall_s=wall, steps=value("NeuralSteps"), train_s=value("NeuralTrainingSeconds"),
             psnr=value("NeuralPSNR"), max_error=value("NeuralMaxError"), ratio=value("NeuralCompressionRatio"),
             source_samples=value("NeuralSourceSamples"), dims=list(out.GetDimensions()),
             bounds=list(out.GetBounds()), curve=curve, messages=catcher.GetOutput()[-3000:])
    r["steps_per_s"] = r["steps"] / r["train_s"] if r["steps"] and r["train_s"] else None
    probe = re.search(r"Probe: (\d+) of (\d+) random points inside the domain \(([\d.]+) s\)", r["messages"])
    if probe:
        r["bank_points"], r["probed"], r["bank_s"] = int(probe.group(1)), int(probe.group(2)), float(probe.group(3))
    built = re.search(r"\(locator ([\d.e+-]+) s\); reconstructed at [^;]* in ([\d.e+-]+) s", r["messages"])
    if built:
        r["locator_s"], r["reconstruct_s"] = float(built.group(1)), float(built.group(2))
    # The run's own memory: its peak resident size above the size before it (the input already made).
    r["base_rss_mib"], r["peak_rss_mib"] = base_mib, memory_mib()[1]
    r["peak_growth_mib"] = r["peak_rss_mib"] - base_mib
    Delete(nc)
    Delete(src)
    return r


t0 = time.time()
result = dict(n=args.n, device=args.device, log2_table=args.log2_table, steps=args.steps, batch=args.batch)
if args.only != "image":
    particles = particle_set(args.n)
    result["generate_s"] = time.time() - t0
    result["particles"] = train(particles, Sampling="Probe", ProbePoints=args.probe_points)
    p = result["particles"]
    p["preparation_s"] = p["wall_s"] - (p["train_s"] or 0.0)
    del particles
    dims, bounds = p["dims"], p["bounds"]
else:
    dims, bounds = [256, 256, 256], [0.05, 0.95, 0.05, 0.95, 0.05, 0.95]
if args.only != "particles":
    result["image"] = train(image_of(dims, bounds))
if "particles" in result and "image" in result:
    p, i = result["particles"], result["image"]
    if p["steps_per_s"] and i["steps_per_s"]:
        result["step_rate_ratio"] = p["steps_per_s"] / i["steps_per_s"]
for name in ("particles", "image"):
    if name not in result:
        continue
    r = result[name]
    print("RESULT %s: %s steps in %.2f s (%.1f steps/s), PSNR %.2f dB, max error %.4f, ratio %.2f, dims %s, "
          "preparation %.2f s%s%s, peak memory %.0f MiB above the input" % (
              name, r["steps"], r["train_s"] or 0, r["steps_per_s"] or 0, r["psnr"] or 0, r["max_error"] or 0,
              r["ratio"] or 0, r["dims"], r["wall_s"] - (r["train_s"] or 0),
              " (locator %.2f s, image reconstruction %.2f s)" % (r["locator_s"], r["reconstruct_s"])
              if "locator_s" in r else "",
              ", bank %d of %d points in %.2f s" % (r["bank_points"], r["probed"], r["bank_s"]) if "bank_s" in r
              else "", r["peak_growth_mib"]))
    c = r["curve"]
    if "PSNR" in c:
        print("RESULT %s PSNR over time (step, s, dB): %s" % (name, " ".join(
            "%d/%.1f/%.2f" % (st, el, ps) for st, el, ps in zip(c["Step"], c["ElapsedSeconds"], c["PSNR"]))))
if "step_rate_ratio" in result:
    print("RESULT step rate particles / image: %.2f (the issue asks >= 0.50)" % result["step_rate_ratio"])
if "particles" in result:
    p = result["particles"]
    print("RESULT memory: %.0f MiB resident with the %d particles made, peak %.0f MiB during their run (+%.0f MiB)"
          % (p["base_rss_mib"], args.n, p["peak_rss_mib"], p["peak_growth_mib"]))
with open(args.out, "w") as f:
    json.dump(result, f, indent=1)
sys.stdout.flush()
