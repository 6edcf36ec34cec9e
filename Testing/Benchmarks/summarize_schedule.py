#!/usr/bin/env python3
"""Summary of a learning-rate schedule log (run_tradeoff_gpu.sh's `schedule`, `anneal` and similar sections: lines
`VARIANT name loss L log2T T volume` each followed by nvBench tradeoff RESULT lines): per volume, loss, table size and
schedule, the PSNR at 1000 and at the last step, the best PSNR and its step, final minus best, the deepest collapse
(largest drop below the best PSNR seen so far) over the whole run and over its last quarter.
usage: summarize_schedule.py schedule.log > table.md"""
import json
import sys
from collections import defaultdict


def collapse(pts):
    """Best PSNR, its step and the deepest drop below the best so far, over (step, psnr) points in order."""
    best, drop, best_step = -1e9, 0.0, 0
    for s, p in pts:
        if p != p:  # NaN: a collapse to nothing
            drop = float("inf")
            continue
        if p > best:
            best, best_step = p, s
        drop = max(drop, best - p)
    return best, best_step, drop


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
    print("| volume | loss | table | schedule | PSNR @1000 | PSNR last | best (step) | last - best | deepest collapse |"
          " collapse in last 25% | train s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    agg = defaultdict(list)
    for (vol, loss, t, var), pts in sorted(runs.items()):
        sp = [(s, p) for s, p, _ in pts]
        best, best_step, drop = collapse(sp)
        last_step = sp[-1][0]
        # the last quarter: drops below the best seen so far (over the whole run) within it
        late = 0.0
        run_best = -1e9
        for s, p in sp:
            if p == p and s > 0.75 * last_step:
                late = max(late, run_best - p)
            elif p != p and s > 0.75 * last_step:
                late = float("inf")
            if p == p:
                run_best = max(run_best, p)
        late = max(late, 0.0)
        at1000 = next((p for s, p in sp if s == 1000), float("nan"))
        print("| %s | %s | 2^%d | %s | %.2f | %.2f | %.2f (%d) | %.2f | %.2f dB | %.2f dB | %.1f |" % (
            vol.split("_")[0], loss, t, var, at1000, sp[-1][1], best, best_step, sp[-1][1] - best, drop, late,
            pts[-1][2]))
        agg[(loss, t, var)].append((sp[-1][1], drop, best, sp[-1][1] - best, late))
    print()
    print("| loss | table | schedule | runs | mean last PSNR | mean best | worst last - best | mean collapse |"
          " worst collapse in last 25% |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (loss, t, var), v in sorted(agg.items()):
        n = len(v)
        print("| %s | 2^%d | %s | %d | %.2f | %.2f | %.2f | %.2f dB | %.2f dB |" % (
            loss, t, var, n, sum(a[0] for a in v) / n, sum(a[2] for a in v) / n, min(a[3] for a in v),
            sum(a[1] for a in v) / n, max(a[4] for a in v)))


if __name__ == "__main__":
    main(sys.argv[1])
