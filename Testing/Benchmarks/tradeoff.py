#!/usr/bin/env python3
"""Run time against error: the neural representation (GPU and CPU engines) against ZFP and SZ3, and the paper's
method in PyTorch. One command runs the whole sweep and writes CSV + plots:

  tradeoff.py run --nvbench BUILD/Testing/Benchmarks/nvBench --out DIR [--device cuda,cpu] [--volumes a.nhdr ..]
                  [--tables 12,14,16,18,20] [--steps 250,500,1000,2000,4000,8000] [--cpu-tables 14,18]
                  [--cpu-steps 250,500,1000] [--storage fp16,q8] [--torch REFERENCE_DIR] [--tiny]

Without --volumes: every regular-grid volume of ../shared/data (*.nhdr). --tiny: two synthetic 32^3 volumes, two
table sizes, few steps (the CI run). Sub-commands used by `run`, also usable alone:
  tradeoff.py neural ...  |  tradeoff.py compressors ...  |  tradeoff.py torch ...  |  tradeoff.py plot CSV.. --out DIR
  tradeoff.py check CSV   (every column present, every metric finite)
Competitors (tradeoff_codecs.py), each row's method naming its mode: ZFP zfp-accuracy (tolerance swept until the
ratio passes the largest target), zfp-precision, zfp-rate; SZ3 sz3-abs / sz3-rel / sz3-psnr with the bound bisected
to within 2% of each target ratio: the network ratios of --targets-from CSVs (`run`: its own neural rows) and
--targets. `compressors --codecs sz3 --skip-targets-in CSV` searches only targets not searched yet. --seeds and
--torch-seeds repeat the neural and PyTorch runs per seed (column seed). The rate-distortion table from these CSVs:
tradeoff_table.py; its procedural 512^3 volumes: tradeoff_volumes.py.
Rows: date, machine, gpu, commit, volume, dims, source_bytes, method, setting, steps, ratio, compress_s, decompress_s,
psnr, max_error, ssim, target_ratio, seed (volumes above 2^25 voxels: ssim not computed). compress_s is the training
time for the neural rows (setup excluded), decompress_s the decode of the whole grid into host memory. Ratios are source bytes (the volume's own type) over stored bytes (the network as
stored, ZFP/SZ3 stream). --storage (the neural sweep; default both): fp16 rows are the methods neural-gpu / neural-cpu,
8-bit entropy-coded rows (Neural Compress's StoragePrecision "8-bit (entropy coded)") neural-gpu-q8 / neural-cpu-q8;
both come from the same training run (nvBench tradeoff --storage), so their compress_s are the same."""
import argparse
import csv
import datetime
import glob
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tradeoff_codecs as tc  # noqa: E402
import tradeoff_metrics as tm  # noqa: E402

COLUMNS = ["date", "machine", "gpu", "commit", "volume", "dims", "source_bytes", "method", "setting", "steps", "ratio",
           "compress_s", "decompress_s", "psnr", "max_error", "ssim", "target_ratio", "seed"]
# Columns of this harness's later rows: CSVs written before them (results/tradeoff_2026-11-2*) still load.
LATER_COLUMNS = ("target_ratio", "seed")
MIN_TARGET = 1.0  # network ratios up to this are no target: the network is not smaller than the volume
IMAGE_METRIC_MAX_VOXELS = 1 << 25  # above this (e.g. 512^3) the rendered-image SSIM is not computed (ssim empty)
SZ3_METHODS = ["sz3-" + m for m in tc.SZ3_MODES]
ZFP_METHODS = ["zfp-accuracy", "zfp-precision", "zfp-rate"]
# Columns a method does not measure (the PyTorch reference prints PSNR and training time only).
NOT_MEASURED = {"pytorch-ref": {"ratio", "decompress_s", "max_error", "ssim"}}
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
STORAGES = ("fp16", "q8")
# Plot styles of the 8-bit rows (tradeoff_plot.py styles the others).
def neural_method(device, storage):
    return "neural-" + ("gpu" if device == "cuda" else "cpu") + ("-q8" if storage == "q8" else "")


def storage_option(storages):
    return "both" if len(storages) == 2 else storages[0]


def context():
    gpu = ""
    try:
        gpu = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                             text=True, timeout=20).stdout.strip().splitlines()[0]
    except (OSError, IndexError, subprocess.SubprocessError):
        gpu = "none"
    commit = "unknown"
    try:
        commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                timeout=20).stdout.strip() or commit
    except (OSError, subprocess.SubprocessError):
        pass
    # The device machine's copy of the tree has no git history: the binaries' commit travels in .devcarry/COMMIT.
    if os.path.exists(os.path.join(ROOT, ".devcarry", "COMMIT")):
        commit = open(os.path.join(ROOT, ".devcarry", "COMMIT")).read().strip()
    cpu = platform.processor() or platform.machine()
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"date": datetime.date.today().isoformat(), "machine": "%s, %d cores" % (cpu, os.cpu_count()),
            "gpu": gpu, "commit": commit}


def volume_row(ctx, path, original):
    nz, ny, nx = original.shape
    return dict(ctx, volume=volume_name(path), dims="%dx%dx%d" % (nx, ny, nz),
                source_bytes=original.nbytes)


def fmt(v):
    return "%.6g" % v if isinstance(v, float) else v


class Writer:
    def __init__(self, path):
        self.path = path
        new = not os.path.exists(path) or os.path.getsize(path) == 0
        if not new and open(path).readline().strip() != ",".join(COLUMNS):
            raise SystemExit("%s has other columns (an older harness's): pass another --out" % path)
        self.f = open(path, "a", newline="")
        self.w = csv.DictWriter(self.f, COLUMNS)
        if new:
            self.w.writeheader()

    def add(self, row):
        self.w.writerow({k: fmt(row.get(k, "")) for k in COLUMNS})
        self.f.flush()
        print("  %-10s %-12s %-10s steps %-5s ratio %8s  psnr %6.2f  ssim %s  t %.3fs" % (
            row["volume"], row["method"], row["setting"], row.get("steps", ""), fmt(row["ratio"]), row["psnr"],
            "%.4f" % row["ssim"] if isinstance(row.get("ssim"), float) else "-", row["compress_s"]), flush=True)


def run_neural(args, ctx, writer, volumes, device, tables, steps):
    """nvBench tradeoff per volume, table, seed (and step count: the annealed schedule plans for the run's end).
    Volumes above IMAGE_METRIC_MAX_VOXELS (512^3) are not dumped: PSNR and max error are nvBench's own (the same
    definition, over every voxel), the image metric is not computed."""
    tmp = tempfile.mkdtemp(prefix="nv_tradeoff_")
    for path in volumes:
        original = tm.load_nhdr(path)
        large = original.size > IMAGE_METRIC_MAX_VOXELS
        metric = None if large else tm.ImageMetric(original)
        # The filter's default schedule anneals to the run's last step: one run per step count. The step decay does
        # not depend on the run's length: one run per table, measured at every step count.
        runs = [[n] for n in steps] if args.schedule == "annealed" else [steps]
        for log2t, marks, seed in [(t, m, s) for t in tables for m in runs for s in args.seeds]:
            cmd = [args.nvbench, "tradeoff", device, path, str(log2t), ",".join(map(str, marks)),
                   "--storage=" + storage_option(args.storage)] + ([] if large else ["--dump=" + tmp])
            cmd += ["--schedule=cos", "--hold=500"] if args.schedule == "annealed" else ["--schedule=step"]
            cmd += ["--seed=%d" % seed] if seed else []
            if args.threads:
                cmd.append("--threads=%d" % args.threads)
            if args.batch:
                cmd.append("--batch=%d" % args.batch)
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
            for line in proc.stdout:
                if not line.startswith("RESULT "):
                    continue
                r = json.loads(line[7:])
                if large:
                    psnr, max_error, ssim = r["psnr"], r["max_error"], ""
                    psnr, max_error = (float("nan") if psnr is None else psnr), (float("inf") if max_error is None
                                                                                 else max_error)
                else:
                    decoded = np.fromfile(r["dump"], np.float32).reshape(original.shape)
                    os.remove(r["dump"])
                    psnr, max_error = tm.errors(original, decoded)
                    ssim = metric(decoded)
                row = volume_row(ctx, path, original)
                row.update(method=neural_method(device, r.get("storage", "fp16")), setting="2^%d" % log2t,
                           steps=r["steps"], ratio=r["ratio"], compress_s=r["train_s"], decompress_s=r["decode_s"],
                           psnr=psnr, max_error=max_error, ssim=ssim, seed=seed or "")
                writer.add(row)
            if proc.wait() != 0:
                raise SystemExit("nvBench failed: " + " ".join(cmd))
    os.rmdir(tmp)


def volume_name(path):
    return os.path.basename(path).split("_")[0].replace(".nhdr", "")


def network_ratios(csv_paths, name, dims=None):
    """The ratios of the neural rows of volume `name` (and `dims` when given) at their largest step count: the
    targets of the SZ3 bisection. Ratios within 0.2% of each other count once; below MIN_TARGET none (the network
    is larger than, or as large as, the volume: raw storage wins there)."""
    rows = [r for p in csv_paths for r in csv.DictReader(open(p))
            if r["method"].startswith("neural") and r["volume"] == name and (dims is None or r["dims"] == dims)]
    last = {}
    for r in rows:
        key = (r["method"], r["setting"])
        last[key] = max(last.get(key, 0), int(float(r["steps"])))
    ratios = sorted(float(r["ratio"]) for r in rows if int(float(r["steps"])) == last[(r["method"], r["setting"])])
    kept = []
    for q in ratios:
        if q > MIN_TARGET and (not kept or q > kept[-1] * 1.002):
            kept.append(q)
    return kept


def run_compressors(args, ctx, writer, volumes):
    """ZFP in its three modes and SZ3 bisected to each target ratio in its ABS, REL and PSNR modes (tradeoff_codecs).
    Returns {(volume, dims): targets}."""
    searched = {}
    for path in volumes:
        original = tm.load_nhdr(path)
        nz, ny, nx = original.shape
        dims = "%dx%dx%d" % (nx, ny, nz)
        targets = sorted(set(args.targets + network_ratios(args.targets_from, volume_name(path), dims)))
        done = [float(r["target_ratio"]) for p in args.skip_targets_in for r in csv.DictReader(open(p))
                if r["volume"] == volume_name(path) and r["dims"] == dims and r["method"].startswith("sz3-")
                and r.get("target_ratio")]
        targets = [t for t in targets if not any(abs(d / t - 1) <= 0.005 for d in done)]
        metric = tm.ImageMetric(original) if original.size <= IMAGE_METRIC_MAX_VOXELS else None
        values = original.astype(np.float32)
        lo, hi = float(values.min()), float(values.max())
        rng = hi - lo if hi > lo else 1.0
        largest = max(targets) if targets else max(args.ratios)
        searched[(volume_name(path), dims)] = targets
        print("%s: targets %s" % (volume_name(path), ", ".join("%.4g" % t for t in targets) or "none"), flush=True)

        def record(method, setting, encoded, target=""):
            decoded, decode_s = encoded.decode()
            psnr, max_error = tm.errors(original, decoded)
            row = volume_row(ctx, path, original)
            row.update(method=method, setting=setting, steps="", ratio=original.nbytes / encoded.stream_bytes,
                       compress_s=encoded.compress_s, decompress_s=decode_s, psnr=psnr, max_error=max_error,
                       ssim=metric(decoded) if metric else "", target_ratio=target)
            writer.add(row)

        # A 512^3 volume (one evaluation takes seconds on the CPU): the sweeps start where ratios reach about 3:1,
        # fixed rate only at the targets, the SZ3 grid is coarser (tradeoff_codecs.Sz3Search).
        coarse = original.size > IMAGE_METRIC_MAX_VOXELS
        if "zfp" in args.codecs:
            smallest = min(targets) if targets else None
            for setting, e in tc.zfp_accuracy(values, original.nbytes, rng, largest, 1e-4 if coarse else 1e-5,
                                              smallest):
                record("zfp-accuracy", setting, e)
            for setting, e in tc.zfp_precision(values, original.nbytes, largest, 16 if coarse else 32, smallest):
                record("zfp-precision", setting, e)
            bits = original.dtype.itemsize * 8
            rate_targets = {bits / r: r for r in targets}
            for setting, e in tc.zfp_rate(values, bits, (targets or args.ratios) if coarse else args.ratios + targets):
                rate = float(setting.split()[1])
                record("zfp-rate", setting, e, next((t for b, t in rate_targets.items() if abs(b - rate) < 1e-3 * b),
                                                    ""))
        for mode in args.sz3_modes if "sz3" in args.codecs else []:
            search = tc.Sz3Search(values, original.nbytes, rng, mode, coarse=coarse)
            for target in targets:
                x = search.find(target)
                record("sz3-" + mode, search.describe(x, target), search.encoded(x), target)
    return searched


def run_torch(args, ctx, writer, volumes, tables, steps):
    """The paper's method in PyTorch (../shared/reference/quality_torch.py), run as it is, once per seed of
    --torch-seeds through torch_seeded.py (which only replaces the reference's torch.manual_seed(0) by the seed);
    one process per table and seed trains every volume."""
    ref = os.path.abspath(args.torch)
    seeded = os.path.join(os.path.dirname(os.path.abspath(__file__)), "torch_seeded.py")
    by_name = {os.path.basename(p): p for p in volumes}
    for log2t, seed in [(t, s) for t in tables for s in args.torch_seeds]:
        out = subprocess.run([sys.executable, seeded, str(seed), os.path.join(ref, "quality_torch.py"),
                              os.path.join(ref, "bench_torch.py"), str(max(steps)), str(log2t)] + list(volumes),
                             capture_output=True, text=True)
        results = [json.loads(l[7:]) for l in out.stdout.splitlines() if l.startswith("RESULT ")]
        if out.returncode != 0 or len(results) != len(volumes):
            raise SystemExit("quality_torch.py failed:\n" + out.stderr[-2000:])
        for r in results:
            path = by_name[r["name"]]
            original = tm.load_nhdr(path)
            for s, t, p in r["curve"]:
                row = volume_row(ctx, path, original)
                # The same network as the engine's at this table size: the ratio is the engine's (stored fp16).
                row.update(method="pytorch-ref", setting="2^%d" % log2t, steps=s, ratio="", compress_s=t,
                           decompress_s="", psnr=p, max_error="", ssim="", seed=seed)
                writer.add(row)


def check(path):
    """Every column present; every measured metric finite (NaN never passes; an infinite PSNR only with a max error
    of exactly 0)."""
    rows = list(csv.DictReader(open(path)))
    if not rows:
        raise SystemExit("check: %s has no rows" % path)
    missing = [c for c in COLUMNS if c not in rows[0] and c not in LATER_COLUMNS]
    if missing:
        raise SystemExit("check: missing columns " + ", ".join(missing))
    bad = []
    for i, r in enumerate(rows):
        for c in ("ratio", "compress_s", "decompress_s", "psnr", "max_error", "ssim", "source_bytes"):
            unmeasured_ssim = c == "ssim" and r[c] == "" and voxels(r) > IMAGE_METRIC_MAX_VOXELS
            if c in NOT_MEASURED.get(r["method"], ()) or unmeasured_ssim:
                continue
            try:
                v = float(r[c])
            except ValueError:
                v = float("nan")
            if c == "psnr" and v == float("inf") and r["max_error"] not in ("", None) and float(r["max_error"]) == 0:
                continue  # lossless (a compressor's tightest bound on 8-bit data): exact, not a broken field
            if not math.isfinite(v) or (c in ("ratio", "source_bytes", "compress_s") and v <= 0) or \
                    (c == "ssim" and not -1.0 <= v <= 1.0):
                bad.append("row %d (%s %s %s): %s = %r" % (i + 2, r["volume"], r["method"], r["setting"], c, r[c]))
    if bad:
        raise SystemExit("check: non-finite or impossible values:\n  " + "\n  ".join(bad[:20]))
    methods = sorted({r["method"] for r in rows})
    print("check: %d rows, %d volumes, methods %s: all columns present, all values finite" % (
        len(rows), len({r["volume"] for r in rows}), ", ".join(methods)))
    return rows


def voxels(row):
    return math.prod(int(v) for v in row["dims"].split("x"))


def check_codecs(rows, want_targets, strict, zfp_methods=ZFP_METHODS, sz3_methods=SZ3_METHODS):
    """Every volume has rows of the three ZFP modes and, for every target ratio, one row of each SZ3 mode; the ZFP
    accuracy sweep passes the largest target; each SZ3 row's ratio within tc.TOLERANCE of its target. strict: a miss
    fails; otherwise it is listed (SZ3's ratio can jump over a target: the row then says how far it landed). A row
    marked "floor" (the target below SZ3's smallest ratio: a larger ratio, at SZ3's tightest bound) passes."""
    bad, missed = [], []
    for key, targets in want_targets.items():
        rs = [r for r in rows if (r["volume"], r["dims"]) == key]
        for m in zfp_methods:
            if not any(r["method"] == m for r in rs):
                bad.append("%s: no %s row" % (key[0], m))
        accuracy_ratios = [float(r["ratio"]) for r in rs if r["method"] == "zfp-accuracy"]
        if zfp_methods and targets and max(accuracy_ratios + [0]) <= max(targets):
            bad.append("%s: ZFP fixed-accuracy never passes %.4g:1" % (key[0], max(targets)))
        for m in sz3_methods:
            for t in targets:
                hit = [r for r in rs if r["method"] == m and r["target_ratio"] and
                       abs(float(r["target_ratio"]) / t - 1) < 1e-4]
                if not hit:
                    bad.append("%s: no %s row for target %.4g" % (key[0], m, t))
                elif abs(float(hit[0]["ratio"]) / t - 1) > tc.TOLERANCE and "floor" not in hit[0]["setting"]:
                    missed.append("%s %s target %.4g: ratio %s (%+.1f%%)" % (
                        key[0], m, t, hit[0]["ratio"], 100 * (float(hit[0]["ratio"]) / t - 1)))
    if missed:
        print("SZ3 bisection outside %.0f%% of its target:\n  %s" % (100 * tc.TOLERANCE, "\n  ".join(missed)))
    if bad or (strict and missed):
        raise SystemExit("check: codec rows wrong:\n  " + "\n  ".join(bad + (missed if strict else [])))
    print("check: ZFP (%s) and SZ3 (%s) rows of %d volumes, %d SZ3 targets%s" % (
        ", ".join(zfp_methods), ", ".join(sz3_methods), len(want_targets), sum(len(t) for t in want_targets.values()),
        ", every one within %.0f%%" % (100 * tc.TOLERANCE) if not missed else ""))


def check_q8(rows):
    """Each 8-bit row against the fp16 row of the same training (volume, device, table, steps): a larger ratio (the
    coded network is smaller), the same training time."""
    fp16 = {(r["volume"], r["method"], r["setting"], r["steps"]): r for r in rows
            if r["method"] in ("neural-gpu", "neural-cpu")}
    bad = []
    for r in rows:
        if not r["method"].endswith("-q8"):
            continue
        f = fp16.get((r["volume"], r["method"][:-3], r["setting"], r["steps"]))
        if f is None:
            continue
        if not float(r["ratio"]) > float(f["ratio"]) or r["compress_s"] != f["compress_s"]:
            bad.append("%s %s %s %s: ratio %s (fp16 %s), compress_s %s (fp16 %s)" % (
                r["volume"], r["method"], r["setting"], r["steps"], r["ratio"], f["ratio"], r["compress_s"],
                f["compress_s"]))
    if bad:
        raise SystemExit("check: 8-bit rows not smaller than their fp16 rows:\n  " + "\n  ".join(bad))


def plot(paths, out):
    import tradeoff_plot
    tradeoff_plot.plot(paths, out)


def ints(s):
    return [int(v) for v in s.split(",") if v]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("command", choices=["run", "neural", "compressors", "torch", "plot", "check"])
    p.add_argument("csv", nargs="*", help="CSV files (plot, check)")
    p.add_argument("--nvbench", default=os.path.join(ROOT, "build", "Testing", "Benchmarks", "nvBench"))
    p.add_argument("--out", default="tradeoff_out")
    p.add_argument("--device", default="cuda,cpu")
    p.add_argument("--volumes", nargs="*")
    p.add_argument("--tables", default="12,14,16,18,20")
    p.add_argument("--steps", default="250,500,1000,2000,4000,8000")
    p.add_argument("--cpu-tables", default="14,18")
    p.add_argument("--cpu-steps", default="250,500,1000")
    p.add_argument("--storage", default="fp16,q8",
                   help="how the neural rows store the network: fp16, q8 or fp16,q8 (default: both)")
    p.add_argument("--schedule", choices=["annealed", "step"], default="annealed",
                   help="learning-rate schedule of the neural runs: annealed (Neural Compress's default: 500 steps at "
                        "the full rate, then a cosine to 1/100 at the run's last step; one run per step count) or "
                        "step (the paper's step decay; one run per table)")
    p.add_argument("--seeds", default="0", help="seeds of the neural runs (nvBench --seed; 0: its default)")
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--batch", type=int, default=0, help="training batch (default: the engine's, 65536)")
    p.add_argument("--ratios", default="2,4,8,16,32,64,128,256")
    p.add_argument("--targets", default="",
                   help="target ratios of the SZ3 bisection besides the network's (comma separated)")
    p.add_argument("--targets-from", nargs="*", default=[],
                   help="CSVs of neural rows: each volume's network ratios (largest step count) are SZ3 targets")
    p.add_argument("--codecs", default="zfp,sz3", help="compressors run by `compressors` (zfp, sz3)")
    p.add_argument("--skip-targets-in", nargs="*", default=[],
                   help="CSVs whose SZ3 rows' targets are not searched again (a follow-up run at new ratios)")
    p.add_argument("--sz3-modes", default=",".join(tc.SZ3_MODES), help="SZ3 modes searched (abs, rel, psnr)")
    p.add_argument("--torch", help="folder of quality_torch.py and bench_torch.py (PyTorch with a GPU)")
    p.add_argument("--torch-tables", default="14,18")
    p.add_argument("--torch-steps", default="4000")
    p.add_argument("--torch-seeds", default="1,2,3", help="seeds of the PyTorch reference (torch_seeded.py)")
    p.add_argument("--tiny", action="store_true",
                   help="CI size: two synthetic 32^3 volumes, 2^10 and 2^12, 20 and 60 steps, batch 4096")
    args = p.parse_args()
    args.ratios = [float(v) for v in args.ratios.split(",")]
    args.targets = [float(v) for v in args.targets.split(",") if v]
    args.sz3_modes = [m for m in args.sz3_modes.split(",") if m]
    args.torch_seeds = ints(args.torch_seeds)
    args.seeds = ints(args.seeds)
    if set(args.sz3_modes) - set(tc.SZ3_MODES):
        raise SystemExit("--sz3-modes: abs, rel, psnr")
    args.storage = [s for s in STORAGES if s in args.storage.replace("both", "fp16,q8").split(",")]
    if not args.storage:
        raise SystemExit("--storage: fp16, q8 or fp16,q8")

    if args.command == "check":
        for c in args.csv:
            check(c)
        return
    if args.command == "plot":
        plot(args.csv, args.out)
        return

    os.makedirs(args.out, exist_ok=True)
    if args.tiny:
        volumes = tm.synthetic_volumes(os.path.join(args.out, "volumes"))
        args.tables, args.steps, args.cpu_tables, args.cpu_steps = "10,12", "20,60", "10,12", "20,60"
        args.ratios, args.targets = [4.0, 16.0, 64.0], [4.0, 16.0]
        args.batch = args.batch or 4096
    elif args.volumes:
        volumes = args.volumes
    else:
        volumes = sorted(glob.glob(os.path.join(ROOT, "..", "shared", "data", "*", "*.nhdr")))
    if not volumes:
        raise SystemExit("no volumes (../shared/data absent: pass --volumes or --tiny)")
    ctx = context()
    csv_path = os.path.join(args.out, "tradeoff.csv")
    if args.tiny and os.path.exists(csv_path):
        os.remove(csv_path)  # the tiny run checks its own rows (other runs append to one CSV)
    writer = Writer(csv_path)
    devices = args.device.split(",") if args.device else []
    if args.command in ("run", "neural"):
        for dev in devices:
            tables, steps = (args.tables, args.steps) if dev == "cuda" else (args.cpu_tables, args.cpu_steps)
            run_neural(args, ctx, writer, volumes, dev, ints(tables), ints(steps))
    if args.command == "run":
        args.targets_from = args.targets_from + [csv_path]  # the network rows just measured
    searched = {}
    if args.command in ("run", "compressors"):
        searched = run_compressors(args, ctx, writer, volumes)
    if args.command in ("run", "torch") and args.torch:
        run_torch(args, ctx, writer, volumes, ints(args.torch_tables), ints(args.torch_steps))
    writer.f.close()
    if args.command == "compressors" and ("zfp" in args.codecs or any(searched.values())):
        check_codecs(check(csv_path), searched, False, ZFP_METHODS if "zfp" in args.codecs else [],
                     ["sz3-" + m for m in args.sz3_modes] if "sz3" in args.codecs else [])
    if args.command == "run":
        rows = check(csv_path)
        if args.tiny:
            # Every volume has every method's rows: 2 volumes x (2 tables x 2 marks neural per storage; ZFP's three
            # modes; SZ3's three modes at 4:1, 16:1 and the network's ratios above 1, each within 2%).
            have = {(r["volume"], r["method"]) for r in rows}
            neural_methods = [neural_method(d, s) for d in devices for s in args.storage]
            want = {(v, m) for v in ("marschnerlobb", "noise") for m in neural_methods}
            if want - have:
                raise SystemExit("check: missing rows for " + ", ".join("%s/%s" % k for k in sorted(want - have)))
            keys = sorted({(r["volume"], r["dims"]) for r in rows})
            check_codecs(rows, {k: sorted(set(args.targets + network_ratios([csv_path], *k))) for k in keys}, True)
            neural = [r for r in rows if r["method"].startswith("neural")]
            if len(neural) != 8 * len(neural_methods):
                raise SystemExit("check: %d neural rows, expected %d" % (len(neural), 8 * len(neural_methods)))
            check_q8(rows)
        plot([csv_path], args.out)


if __name__ == "__main__":
    main()
