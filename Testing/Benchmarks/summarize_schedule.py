#!/usr/bin/env python3
"""Summary of run_tradeoff_gpu.sh's `schedule` log: per volume, loss, table size and learning-rate schedule, the PSNR
at 1000 and at the last step, the best PSNR and its step, and the deepest collapse (largest drop below the best PSNR
seen so far). usage: summarize_schedule.py schedule.log > table.md"""
import json
import sys
from collections import defaultdict


def main(path):
    runs = defaultdict(list)
    key = None
    for line in open(path):
        if line.startswith("VARIANT "):
            f = line.split()
            key = (f[6], f[3], int(f[5]), f[1])  # volume, loss, log2T, variant
        elif line.startswith("RESULT ") and key:
            r = json.loads(line[7:])
            runs[key].append((r["steps"], r["psnr"] if r["psnr"] is not None else float("nan"), r["train_s"]))
    print("| volume | loss | table | schedule | PSNR @1000 | PSNR last | best (step) | deepest collapse | train s |")
    print("|---|---|---|---|---|---|---|---|---|")
    agg = defaultdict(list)
    for (vol, loss, t, var), pts in sorted(runs.items()):
        best, drop, best_step = -1e9, 0.0, 0
        for s, p, _ in pts:
            if p != p:  # NaN: a collapse to nothing
                drop = float("inf")
                continue
            if p > best:
                best, best_step = p, s
            drop = max(drop, best - p)
        at1000 = next((p for s, p, _ in pts if s == 1000), float("nan"))
        print("| %s | %s | 2^%d | %s | %.2f | %.2f | %.2f (%d) | %.2f dB | %.2f |" % (
            vol.split("_")[0], loss, t, var, at1000, pts[-1][1], best, best_step, drop, pts[-1][2]))
        agg[(loss, t, var)].append((pts[-1][1], drop, best))
    print()
    print("| loss | table | schedule | mean last PSNR | mean best | mean collapse | worst collapse |")
    print("|---|---|---|---|---|---|---|")
    for (loss, t, var), v in sorted(agg.items()):
        n = len(v)
        print("| %s | 2^%d | %s | %.2f | %.2f | %.2f dB | %.2f dB |" % (
            loss, t, var, sum(a for a, _, _ in v) / n, sum(c for _, _, c in v) / n, sum(b for _, b, _ in v) / n,
            max(b for _, b, _ in v)))


if __name__ == "__main__":
    main(sys.argv[1])
