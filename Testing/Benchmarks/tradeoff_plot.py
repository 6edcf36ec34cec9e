"""Plots of the run-time-versus-error harness (tradeoff.py): per volume, PSNR against compression ratio and PSNR
against compression time, every method on one chart; and one overview image of every volume."""
import math
import os
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import tradeoff_metrics as tm  # noqa: E402

STYLE = {"neural-gpu": ("tab:red", "o", "Neural (GPU)"), "neural-cpu": ("tab:orange", "s", "Neural (CPU)"),
         "neural-gpu-q8": ("darkred", "P", "Neural 8-bit (GPU)"), "neural-cpu-q8": ("saddlebrown", "X", "Neural 8-bit (CPU)"),
         "pytorch-ref": ("tab:purple", "^", "Paper's method, PyTorch (GPU)"),
         "zfp-rate": ("tab:blue", "v", "ZFP fixed rate"), "zfp-accuracy": ("tab:cyan", "<", "ZFP fixed accuracy"),
         "zfp-precision": ("steelblue", ">", "ZFP fixed precision"),
         "sz3-abs": ("tab:green", "D", "SZ3 ABS"), "sz3-rel": ("olive", "d", "SZ3 REL"),
         "sz3-psnr": ("lime", "*", "SZ3 PSNR")}
COMPETITORS = ("zfp-accuracy", "zfp-precision", "zfp-rate", "sz3-abs", "sz3-rel", "sz3-psnr")


_f = tm.number
load = tm.load_rows


def _ratio_panel(ax, rows):
    by = defaultdict(list)
    for r in rows:
        by[r["method"]].append(r)
    for method, rs in by.items():
        if method == "pytorch-ref":
            continue
        color, marker, label = STYLE.get(method, ("k", "x", method))
        if method.startswith("neural"):
            # The longest run of each table size.
            last = {}
            for r in rs:
                if r["setting"] not in last or _f(r["steps"]) > _f(last[r["setting"]]["steps"]):
                    last[r["setting"]] = r
            rs = list(last.values())
            label += ", %s steps" % "/".join(sorted({r["steps"] for r in rs}, key=float))
        # Neural: by table size (ratio); compressors: by their setting's accuracy (PSNR), so a line joins neighbours.
        key = (lambda p: p[0]) if method.startswith("neural") else (lambda p: -p[1])
        pts = sorted(((_f(r["ratio"]), _f(r["psnr"])) for r in rs), key=key)
        pts = [p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1])]
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=color, label=label, ms=4)
    ax.set_xscale("log")
    ax.set_xlabel("compression ratio (source bytes / stored bytes)")
    ax.set_ylabel("PSNR (dB)")
    ax.axvline(8.0, color="0.7", ls=":", lw=1)
    ax.set_ylim(top=min(ax.get_ylim()[1], 75.0))
    ax.grid(alpha=0.3)


def _time_panel(ax, rows):
    curves = defaultdict(list)
    for r in rows:
        if r["method"] in ("neural-gpu", "neural-cpu", "pytorch-ref"):
            curves[(r["method"], r["setting"])].append((_f(r["compress_s"]), _f(r["psnr"])))
    tables = sorted({k[1] for k in curves}, key=lambda s: int(s.split("^")[1]))
    shades = {t: 0.35 + 0.65 * i / max(len(tables) - 1, 1) for i, t in enumerate(tables)}
    for (method, setting), pts in sorted(curves.items()):
        color, marker, label = STYLE[method]
        pts = sorted(pts)
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=color, alpha=shades[setting], ms=3,
                label="%s %s" % (label, setting))
    for method in ("zfp-rate", "zfp-accuracy", "sz3-abs"):
        pts = [(_f(r["compress_s"]), _f(r["psnr"])) for r in rows if r["method"] == method]
        if pts:
            color, marker, label = STYLE[method]
            ax.scatter([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=color, s=14,
                       label=label + " (compress time)")
    ax.set_xscale("log")
    ax.set_xlabel("compression / training time (s)")
    ax.set_ylim(top=min(ax.get_ylim()[1], 75.0))
    ax.set_ylabel("PSNR (dB)")
    ax.grid(alpha=0.3)


def plot(paths, out):
    rows = load(paths)
    os.makedirs(out, exist_ok=True)
    volumes = sorted({r["volume"] for r in rows})
    written = []
    for v in volumes:
        rs = [r for r in rows if r["volume"] == v]
        fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.8))
        _ratio_panel(a, rs)
        _time_panel(b, rs)
        a.legend(fontsize=7)
        b.legend(fontsize=6, ncol=2)
        fig.suptitle("%s (%s, %s bytes) - %s, GPU: %s, commit %s" % (v, rs[0]["dims"], rs[0]["source_bytes"],
                                                                   rs[0]["date"], rs[0]["gpu"], rs[0]["commit"]))
        fig.tight_layout()
        name = os.path.join(out, "tradeoff_%s.png" % v)
        fig.savefig(name, dpi=90)
        plt.close(fig)
        written.append(name)
    # Overview: PSNR vs ratio of every volume, one small chart each.
    n = len(volumes)
    cols = min(4, n)
    rows_n = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows_n, cols, figsize=(4.2 * cols, 3.4 * rows_n), squeeze=False)
    for ax, v in zip(axes.flat, volumes):
        _ratio_panel(ax, [r for r in rows if r["volume"] == v])
        ax.set_title(v, fontsize=10)
        ax.xaxis.label.set_size(7)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    name = os.path.join(out, "tradeoff_overview.png")
    fig.savefig(name, dpi=80)
    plt.close(fig)
    written.append(name)
    print("plots: " + ", ".join(written))
    return written


def _rd_ratio_panel(ax, rows):
    """The table's view: networks at each table's longest run, each competitor mode as a line by ratio (SZ3: its
    bisected rows, labelled by their targets)."""
    last = {}
    for r in rows:
        if r["method"] in ("neural-gpu", "neural-gpu-q8"):
            key = (r["method"], r["setting"])
            if key not in last or _f(r["steps"]) > _f(last[key]["steps"]):
                last[key] = r
    for method in ("neural-gpu", "neural-gpu-q8") + COMPETITORS:
        if method.startswith("neural"):
            rs = [r for k, r in last.items() if k[0] == method]
        else:
            rs = [r for r in rows if r["method"] == method]
        pts = sorted((_f(r["ratio"]), _f(r["psnr"])) for r in rs)
        pts = [q for q in pts if math.isfinite(q[0]) and math.isfinite(q[1]) and q[0] >= 0.5]
        if pts:
            color, marker, label = STYLE[method]
            if method.startswith("neural"):
                label += " (%s steps)" % "/".join(sorted({r["steps"] for r in rs}, key=float))
            ax.plot([q[0] for q in pts], [q[1] for q in pts], marker=marker, color=color, label=label, ms=4,
                    lw=2 if method.startswith("neural") else 1)
    ax.set_xscale("log")
    ax.axvline(15.0, color="0.6", ls=":", lw=1)
    ax.set_xlabel("compression ratio (source bytes / stored bytes)")
    ax.set_ylabel("PSNR (dB)")
    lo, hi = ax.get_ylim()
    ax.set_ylim(max(lo, 15.0), min(hi, 80.0))
    ax.grid(alpha=0.3)


def _rd_time_panel(ax, rows, seeds, volume, dims):
    """PSNR against training seconds: the engine (fp16, first seed) per table, the PyTorch reference's mean over
    seeds per step count with its min-max."""
    curves = defaultdict(list)
    for r in rows:
        first_seed = r.get("seed", "") in ("", "1")
        if r["method"] == "neural-gpu" and r["volume"] == volume and r["dims"] == dims and first_seed:
            curves[r["setting"]].append((_f(r["compress_s"]), _f(r["psnr"])))
    for i, (table, pts) in enumerate(sorted(curves.items(), key=lambda kv: int(kv[0].split("^")[1]))):
        pts = sorted(pts)
        ax.plot([q[0] for q in pts], [q[1] for q in pts], marker="o", ms=3, color=plt.cm.Reds(0.4 + 0.12 * i),
                label="engine fp16 %s" % table)
    torch = defaultdict(lambda: defaultdict(list))
    for v, d, impl, table, seed, steps, sec, p in seeds:
        if impl == "pytorch" and v == volume and d == dims:
            torch[table][steps].append((sec, p))
    for i, (table, by_steps) in enumerate(sorted(torch.items())):
        xs, ys, lo, hi = [], [], [], []
        for steps in sorted(by_steps):
            runs = by_steps[steps]
            xs.append(sum(s for s, _ in runs) / len(runs))
            ps = [p for _, p in runs]
            ys.append(sum(ps) / len(ps))
            lo.append(ys[-1] - min(ps))
            hi.append(max(ps) - ys[-1])
        n = max(len(v) for v in by_steps.values())
        ax.errorbar(xs, ys, yerr=[lo, hi], marker="^", ms=3, capsize=2, color=plt.cm.Purples(0.5 + 0.15 * i),
                    label="PyTorch %s (mean of %d seeds, min-max)" % (table, n))
    ax.set_xscale("log")
    ax.set_xlabel("training time (s)")
    ax.set_ylabel("PSNR (dB)")
    ax.grid(alpha=0.3)


def plot_rd(rows, seeds, out):
    """One image per volume with network rows: PSNR against ratio, PSNR against training seconds."""
    os.makedirs(out, exist_ok=True)
    keys = sorted({(r["volume"], r["dims"]) for r in rows if r["method"].startswith("neural-gpu")})
    written = []
    for v, d in keys:
        rs = [r for r in rows if r["volume"] == v and r["dims"] == d]
        fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.8))
        _rd_ratio_panel(a, rs)
        _rd_time_panel(b, rows, seeds, v, d)
        a.legend(fontsize=7)
        b.legend(fontsize=6)
        fig.suptitle("%s (%s): PSNR against ratio (dotted: 15:1) and against training time" % (v, d))
        fig.tight_layout()
        name = os.path.join(out, "rd_%s_%s.png" % (v, d))
        fig.savefig(name, dpi=80)
        plt.close(fig)
        written.append(name)
    print("plots: " + ", ".join(written))
    return written
