"""Plots of the render benchmark (nvBenchRender) for the README: FPS per path and shading mode, and the Sample
Streaming K sweep. Usage: /usr/bin/python3 plot_render.py RENDER_720.log SWEEP.log OUTDIR"""
import json
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def results(path):
    out = []
    for line in open(path):
        if line.startswith("RESULT "):
            out.append(json.loads(line[7:]))
    return out


render = [r for r in results(sys.argv[1]) if r["what"] == "render"]
sweep = [r for r in results(sys.argv[2]) if r["what"] == "render"]
outdir = sys.argv[3]

paths = ["Decode", "Sample Streaming", "In-Shader"]
modes = ["Ray Marching", "Ray Marching + Gradient Shading", "Ray Marching + Shadows", "Path Tracing",
         "Path Tracing + NEE"]
short = ["RM", "RM + gradient", "RM + shadows", "PT (1 spp)", "PT + NEE (1 spp)"]
fig, ax = plt.subplots(figsize=(8, 3.6))
w = 0.26
for i, p in enumerate(paths):
    fps = [next((1000.0 / r["ms_render"] for r in render if r["path"] == p and r["mode"] == m), 0) for m in modes]
    ax.bar([k + (i - 1) * w for k in range(len(modes))], fps, w, label=p)
ax.set_yscale("log")
ax.set_xticks(range(len(modes)))
ax.set_xticklabels(short)
ax.set_ylabel("frames per second (GPU time)")
ax.axhline(60, color="grey", lw=0.8, ls="--")
ax.set_title("stent 128x128x256, 1280x720, H100, network 2^14 table, 1 sample per voxel")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(outdir + "/gpu_render_fps.png", dpi=110)

fig, ax = plt.subplots(figsize=(5, 3))
ks = [r["K"] for r in sweep]
ax.plot(ks, [r["ms_render"] for r in sweep], "o-")
ax.set_xscale("log", base=2)
ax.set_xlabel("K (samples a ray advances per wavefront)")
ax.set_ylabel("ms per frame")
ax.set_title("Sample Streaming, ray marching, 1280x720")
fig.tight_layout()
fig.savefig(outdir + "/gpu_render_ksweep.png", dpi=110)
