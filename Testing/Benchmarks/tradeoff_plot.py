"""Plots of the run-time-versus-error harness (tradeoff.py): per volume, PSNR against compression ratio and PSNR
against compression time, every method on one chart; and one overview image of every volume."""
import csv
import math
import os
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {"neural-gpu": ("tab:red", "o", "Neural (GPU)"), "neural-cpu": ("tab:orange", "s", "Neural (CPU)"),
         "neural-gpu-q8": ("darkred", "P", "Neural 8-bit (GPU)"), "neural-cpu-q8": ("saddlebrown", "X", "Neural 8-bit (CPU)"),
         "pytorch-ref": ("tab:purple", "^", "Paper's method, PyTorch (GPU)"),
         "zfp-rate": ("tab:blue", "v", "ZFP fixed rate"), "zfp-accuracy": ("tab:cyan", "<", "ZFP fixed accuracy"),
         "sz3-abs": ("tab:green", "D", "SZ3 (abs. error bound)")}


def _f(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def load(paths):
    rows = []
    for p in paths:
        rows += list(csv.DictReader(open(p)))
    return rows


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
