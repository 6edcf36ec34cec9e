"""Plots the warm-start benchmark (nvBenchOnline warm): steps to the cold-start PSNR per time step, cold vs warm,
for each series. Usage: /usr/bin/python3 plot_online.py RAW_DIR OUT.png"""
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

raw, out = sys.argv[1], sys.argv[2]
series = [("online_warm_flow.log", "OpenLB flow |u| (33x44x28), 2^14 table"),
          ("online_warm_cth.log", "CTH pressure, AMR resampled to 80^3, 2^16 table")]
fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
for ax, (name, title) in zip(axes, series):
    rows = [json.loads(line.split("RESULT ", 1)[1]) for line in open(os.path.join(raw, name))
            if line.startswith("RESULT") and '"warm_start"' in line]
    labels = [r["file"].split("_")[-1].split(".")[0] for r in rows]
    x = range(len(rows))
    ax.bar([i - 0.2 for i in x], [r["cold_steps"] for r in rows], 0.4, label="cold start")
    ax.bar([i + 0.2 for i in x], [r["warm_steps"] for r in rows], 0.4, label="warm start (network of t-1)")
    cold, warm = sum(r["cold_steps"] for r in rows), sum(r["warm_steps"] for r in rows)
    ax.set_title("%s\nall steps: warm %d vs cold %d (%.0f%%)" % (title, warm, cold, 100.0 * warm / cold), fontsize=9)
    ax.set_xticks(list(x))
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_xlabel("time step")
    ax.set_ylabel("steps until the probe first reaches it")
    ax.legend(fontsize=8)
fig.suptitle("Warm start (H100): steps to reach the PSNR a cold start has after 1000 steps (probe every 10 steps)", fontsize=10)
fig.tight_layout()
fig.savefig(out, dpi=110)
