#!/usr/bin/env python3
"""The rate-distortion table of issue 25 from the harness's CSVs (tradeoff.py): for each volume and each network
ratio, the best competitor at that ratio (ZFP's best of fixed-accuracy / fixed-precision / fixed-rate, SZ3 bisected
to that ratio in its best of ABS / REL / PSNR) against the network, the dB difference, and where the network loses;
the PyTorch reference over seeds against the engine at equal steps and at equal wall time; plots of PSNR against
ratio and against training seconds.

  tradeoff_table.py CSV.. [--legacy-seeds seeds_results.csv] --md OUT.md --csv OUT.csv --plots DIR [--title T]

Network rows: neural-gpu (fp16) and neural-gpu-q8 (8-bit entropy coded) at each table's largest step count (the
first seed's when there are several). ZFP at the network's ratio: a mode's row within 2% of it (fixed rate is run at
the ratio itself) or the PSNR interpolated linearly in log(ratio) between the mode's two rows around it (the bracket
is in the table). SZ3: the bisected row of that target; a row that missed by more than 2% counts only if its ratio is
larger than the network's (it can only lose by that), a "floor" row likewise (SZ3 near-lossless compresses more)."""
import argparse
import csv
import math
import os
from collections import defaultdict

import tradeoff_metrics as tm  # noqa: E402

TOLERANCE = 0.02
NETWORKS = {"neural-gpu": "fp16", "neural-gpu-q8": "8-bit"}
ZFP = ("zfp-accuracy", "zfp-precision", "zfp-rate")
SZ3 = ("sz3-abs", "sz3-rel", "sz3-psnr")
OUT_COLUMNS = ["volume", "dims", "storage", "table", "steps", "net_ratio", "net_psnr", "zfp_mode", "zfp_psnr",
               "zfp_at", "sz3_mode", "sz3_ratio", "sz3_floor", "sz3_psnr", "sz3_setting", "best", "best_psnr",
               "delta_db", "delta_zfp_db",
               "verdict"]


f = tm.number
load = tm.load_rows


def network_rows(rows):
    """(volume, dims) -> the neural rows at each (method, table)'s largest step count, first seed."""
    best = {}
    for r in rows:
        if r["method"] not in NETWORKS:
            continue
        key = (r["volume"], r["dims"], r["method"], r["setting"])
        if key not in best or f(r["steps"]) > f(best[key]["steps"]):
            best[key] = r
    out = defaultdict(list)
    for (v, d, _, _), r in sorted(best.items(), key=lambda kv: f(kv[1]["ratio"])):
        out[(v, d)].append(r)
    return out


def zfp_at(rows, ratio):
    """(psnr, how) of one ZFP mode's rows at `ratio`, or (nan, reason)."""
    pts = sorted((f(r["ratio"]), f(r["psnr"])) for r in rows)
    near = [p for p in pts if abs(p[0] / ratio - 1) <= TOLERANCE]
    if near:
        q = min(near, key=lambda p: abs(p[0] / ratio - 1))
        return q[1], "%.3g:1" % q[0]
    below = [p for p in pts if p[0] < ratio]
    above = [p for p in pts if p[0] > ratio]
    if not below or not above:
        return float("nan"), "not reached"
    a, b = below[-1], above[0]
    if not (math.isfinite(a[1]) and math.isfinite(b[1])):
        return float("nan"), "lossless neighbour"
    w = math.log(ratio / a[0]) / math.log(b[0] / a[0])
    return a[1] + w * (b[1] - a[1]), "interp. %.3g-%.3g:1" % (a[0], b[0])


def sz3_at(rows, ratio):
    """The SZ3 row of the target nearest `ratio` (within 0.5%), usable if within 2% or at a larger ratio."""
    cands = [r for r in rows if r.get("target_ratio") and abs(f(r["target_ratio"]) / ratio - 1) <= 0.005]
    if not cands:
        return None
    r = min(cands, key=lambda r: abs(f(r["target_ratio"]) / ratio - 1))
    ok = abs(f(r["ratio"]) / ratio - 1) <= TOLERANCE or f(r["ratio"]) > ratio
    return r if ok else None


def compare(rows):
    """One output row per network row."""
    by = defaultdict(list)
    for r in rows:
        by[(r["volume"], r["dims"], r["method"])].append(r)
    out = []
    for (v, d), nets in sorted(network_rows(rows).items()):
        for n in nets:
            ratio, psnr = f(n["ratio"]), f(n["psnr"])
            o = dict(volume=v, dims=d, storage=NETWORKS[n["method"]], table=n["setting"], steps=n["steps"],
                     net_ratio="%.4g" % ratio, net_psnr="%.2f" % psnr)
            if ratio <= 1.0:
                o.update(verdict="network larger than the volume (raw storage wins)")
                out.append(o)
                continue
            zfp = [(zfp_at(by[(v, d, m)], ratio), m) for m in ZFP if by[(v, d, m)]]
            zfp = [z for z in zfp if math.isfinite(z[0][0])]
            if zfp:
                (zp, how), zm = max(zfp, key=lambda z: z[0][0])
                o.update(zfp_mode=zm[4:], zfp_psnr="%.2f" % zp, zfp_at=how, delta_zfp_db="%+.2f" % (psnr - zp))
            sz = [r for r in (sz3_at(by[(v, d, m)], ratio) for m in SZ3) if r]
            larger = False
            if not sz:  # not bisected to this ratio: SZ3's best row at a larger ratio bounds it from below
                sz = [r for m in SZ3 for r in by[(v, d, m)] if f(r["ratio"]) >= ratio and math.isfinite(f(r["psnr"]))]
                larger = bool(sz)
            if sz:
                s = max(sz, key=lambda r: f(r["psnr"]))
                o.update(sz3_mode=s["method"][4:],
                         sz3_ratio="%.4g" % f(s["ratio"]),
                         sz3_floor="larger" if larger else "floor" if "floor" in s["setting"] else "",
                         sz3_psnr="%.2f" % f(s["psnr"]),
                         sz3_setting=s["setting"])
            cands = [(f(o[k + "_psnr"]), k.upper()) for k in ("zfp", "sz3") if o.get(k + "_psnr")]
            if not cands:
                o.update(verdict="no competitor row at this ratio")
            else:
                bp, bk = max(cands)
                o.update(best=bk, best_psnr="%.2f" % bp, delta_db="%+.2f" % (psnr - bp),
                         verdict="network ahead" if psnr > bp else "network loses")
                if psnr > bp and not o.get("sz3_psnr"):  # never "ahead" of a compressor that was not run there
                    o.update(verdict="ahead of ZFP; SZ3 not run at this ratio or above")
                elif psnr > bp and larger:  # SZ3 at a larger ratio is only a lower bound of SZ3 at this one
                    o.update(verdict="ahead of SZ3 at a larger ratio; SZ3 not bisected to this one")
            out.append(o)
    return out


def bar_rows(rows, compared):
    """Volumes without network rows yet (512^3 before the GPU run): the competitors' best at each SZ3 target."""
    by = defaultdict(list)
    for r in rows:
        by[(r["volume"], r["dims"], r["method"])].append(r)
    lines = []
    for v, d in sorted({(r["volume"], r["dims"]) for r in rows if r["method"] in SZ3} - compared):
        for t in sorted({f(r["target_ratio"]) for r in rows if (r["volume"], r["dims"]) == (v, d) and
                         r["method"] in SZ3 and r.get("target_ratio")}):
            zfp = [(zfp_at(by[(v, d, m)], t), m) for m in ZFP if by[(v, d, m)]]
            zfp = [z for z in zfp if math.isfinite(z[0][0])]
            sz = [r for r in (sz3_at(by[(v, d, m)], t) for m in SZ3) if r]
            z = max(zfp, key=lambda z: z[0][0]) if zfp else None
            b = max(sz, key=lambda r: f(r["psnr"])) if sz else None
            lines.append("| %s %s | %.4g:1 | %s | %s |" % (
                v, d, t, "%s %.2f (%s)" % (z[1][4:], z[0][0], z[0][1]) if z else "not reached",
                "%s %s (%.4g:1)" % (b["method"][4:], fmt_db(f(b["psnr"])), f(b["ratio"])) if b else "-"))
    if not lines:
        return []
    return ["", "Volumes without network rows yet: the competitors at the SZ3 targets (the network's fp16 ratios of "
            "the GPU run's tables)", "", "| volume | target | ZFP best mode | SZ3 best mode (its ratio) |",
            "|---|---|---|---|"] + lines


def sz3_ratio_text(o):
    """"10.3:1", "6.9:1, floor" when SZ3's smallest ratio is above the network's (compared at a larger ratio), or
    "71.9:1, larger" when SZ3 was not bisected to the network's ratio and its best row at a larger ratio stands in
    (a lower bound of SZ3 there: the network can lose, never win, by that comparison)."""
    note = {"floor": ", floor", "larger": ", larger"}.get(o.get("sz3_floor", ""), "")
    return "%s:1%s" % (o.get("sz3_ratio", ""), note) if o.get("sz3_ratio") else ""


def fmt_db(v):
    return "lossless" if v == float("inf") else "%.2f" % v


def write_md(path, text):
    """Replace the text between the markers of an existing file (the hand-written notes around it stay), else write
    the whole file."""
    begin, end = "<!-- generated by tradeoff_table.py: begin -->", "<!-- generated by tradeoff_table.py: end -->"
    if os.path.exists(path):
        old = open(path).read()
        if begin in old and end in old:
            text = old[:old.index(begin) + len(begin)] + "\n" + text + old[old.index(end):]
    open(path, "w").write(text)


def readme_rows(out, min_ratio):
    """The README's short table: network rows at ratios >= min_ratio with a competitor, and one line per volume."""
    rows = [o for o in out if o.get("delta_db") and f(o["net_ratio"]) >= min_ratio]
    md = ["| volume | network (steps) | ratio | PSNR | ZFP, best mode | SZ3 bisected, best mode | network - ZFP | "
          "network - best |", "|---|---|---|---|---|---|---|---|"]
    md += ["| %s | %s %s (%s) | %s:1 | %s | %s %s | %s %s (%s) | %s | **%s** |" % (
        o["volume"], o["table"], o["storage"], o["steps"], o["net_ratio"], o["net_psnr"], o.get("zfp_mode", "-"),
        o.get("zfp_psnr", ""), o.get("sz3_mode", "-"), fmt_db(f(o.get("sz3_psnr")))
        if o.get("sz3_psnr") else "", sz3_ratio_text(o), o.get("delta_zfp_db", "-"),
        o["delta_db"].replace("-inf", "(lossless)")) for o in rows]
    lose = [o for o in rows if o["verdict"] == "network loses"]
    win = [o for o in rows if o["verdict"] == "network ahead"]
    md += ["", "At ratios of %g:1 and above the network loses in %d of %d comparisons%s%s." % (
        min_ratio, len(lose), len(rows), (": " + ", ".join("%s %s:1 (%s dB)" % (o["volume"], o["net_ratio"],
                                                                             o["delta_db"]) for o in lose)) if lose
        else "", ("; it is ahead at " + ", ".join("%s %s:1 (%s dB)" % (o["volume"], o["net_ratio"], o["delta_db"])
                                                 for o in win)) if win else "; it is ahead nowhere")]
    open_rows = [o for o in rows if o["verdict"].startswith("ahead of")]
    if open_rows:
        md[-1] = md[-1][:-1] + "; undecided where SZ3 was not run at the network's ratio (%s: %s)." % (
            "ahead of ZFP and of SZ3 at a larger ratio only", ", ".join(
                "%s %s:1 (%s dB)" % (o["volume"], o["net_ratio"], o["delta_db"]) for o in open_rows))
    return md


def loses_line(v, d, rs):
    cmp_rows = [r for r in rs if r.get("delta_db")]
    lose = [r for r in cmp_rows if r["verdict"] == "network loses"]
    win = [r for r in cmp_rows if r["verdict"] == "network ahead"]
    bigger = [r for r in rs if r["verdict"].startswith("network larger")]
    parts = []
    if lose:
        parts.append("the network loses at %s" % ", ".join("%s:1 (%s %s, %s vs %s)" % (
            r["net_ratio"], r["table"], r["storage"], "lossless" if r["delta_db"] == "-inf" else r["delta_db"] + " dB",
            r["best"]) for r in lose))
    if win:
        parts.append("is ahead at %s" % ", ".join("%s:1 (%s dB)" % (r["net_ratio"], r["delta_db"]) for r in win))
    undecided = [r for r in cmp_rows if r["verdict"].startswith("ahead of")]
    if undecided:
        parts.append("is ahead of ZFP, SZ3 not run at the ratio, at %s" % ", ".join(
            "%s:1 (%s dB)" % (r["net_ratio"], r["delta_db"]) for r in undecided))
    if bigger:
        parts.append("%d networks are larger than the volume" % len(bigger))
    return "- **%s** (%s): %s." % (v, d, "; ".join(parts) if parts else "no comparison")


def legacy_seeds(path):
    """results/tradeoff_2026-11-25/seeds_results.csv as (volume, dims, impl, table, seed, steps, train_s, psnr)."""
    out = []
    for r in csv.DictReader(open(path)):
        impl = "pytorch" if r["implementation"].startswith("PyTorch") else (
            "engine" if r["schedule"] == "hold500" else None)
        if impl:
            parts = r["volume"].split("_")
            out.append((parts[0], parts[1], impl, "2^" + r["log2T"], r["seed"], int(r["steps"]), f(r["train_s"]),
                        f(r["psnr"])))
    return out


def seed_rows(rows, legacy):
    out = list(legacy)
    for r in rows:
        if r["method"] == "pytorch-ref" or (r["method"] == "neural-gpu" and r.get("seed")):
            out.append((r["volume"], r["dims"], "pytorch" if r["method"] == "pytorch-ref" else "engine",
                        r["setting"], r.get("seed") or "0", int(f(r["steps"])), f(r["compress_s"]), f(r["psnr"])))
    return out


def torch_table(rows, seeds, steps=4000):
    """PyTorch over seeds against the engine (default schedule) at `steps` and at equal wall time."""
    groups = defaultdict(lambda: defaultdict(dict))
    for v, d, impl, t, seed, s, sec, p in seeds:
        if s == steps:
            groups[(v, d, t)][impl][seed] = (sec, p)
    lines = []
    for (v, d, t), g in sorted(groups.items()):
        if "pytorch" not in g:
            continue
        tp = [p for _, p in g["pytorch"].values()]
        tt = sum(s for s, _ in g["pytorch"].values()) / len(tp)
        mean = sum(tp) / len(tp)
        eng = [p for _, p in g.get("engine", {}).values()]
        e_mean = sum(eng) / len(eng) if eng else float("nan")
        wall = [f(r["psnr"]) for r in rows if r["method"] == "neural-gpu" and r["volume"] == v and
                r["dims"] == d and r["setting"] == t and f(r["compress_s"]) <= tt]
        lines.append("| %s | %s | %s | %.2f (%d seed%s, %.2f-%.2f) | %.1f s | %s | %s | %s |" % (
            v, d, t, mean, len(tp), "s" if len(tp) > 1 else "", min(tp), max(tp), tt,
            "%.2f (%d)" % (e_mean, len(eng)) if eng else "-", "%+.2f" % (e_mean - mean) if eng else "-",
            "%.2f (%+.2f)" % (max(wall), max(wall) - mean) if wall else "-"))
    head = ["| volume | dims | table | PyTorch at %d steps: mean (seeds, min-max) | its mean wall time | engine at %d "
            "steps: mean (seeds) | engine - PyTorch, equal steps | engine's best within that wall time (difference) |"
            % (steps, steps), "|---|---|---|---|---|---|---|---|"]
    return head + lines


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv", nargs="+")
    p.add_argument("--legacy-seeds")
    p.add_argument("--md", required=True)
    p.add_argument("--csv-out", required=True)
    p.add_argument("--plots")
    p.add_argument("--readme", help="README.md whose generated part (between the markers) gets the short table")
    p.add_argument("--readme-min-ratio", type=float, default=3.0)
    args = p.parse_args()
    rows = load(args.csv)
    out = compare(rows)
    with open(args.csv_out, "w", newline="") as fh:
        w = csv.DictWriter(fh, OUT_COLUMNS)
        w.writeheader()
        for o in out:
            w.writerow({k: o.get(k, "") for k in OUT_COLUMNS})
    md = ["", "| volume | network | steps | ratio | PSNR | ZFP best mode at that ratio | SZ3 "
          "bisected, best mode (its ratio) | best competitor | network - ZFP | network - best |",
          "|---|---|---|---|---|---|---|---|---|---|"]
    for o in out:
        if o["verdict"].startswith("network larger"):
            continue  # counted per volume below
        if not o.get("delta_db"):
            md.append("| %s %s | %s %s | %s | %s:1 | %s | - | - | - | - | %s |" % (
                o["volume"], o["dims"], o["table"], o["storage"], o["steps"], o["net_ratio"], o["net_psnr"],
                o["verdict"]))
            continue
        md.append("| %s %s | %s %s | %s | %s:1 | %s | %s | %s | %s | %s | **%s** |" % (
            o["volume"], o["dims"], o["table"], o["storage"], o["steps"], o["net_ratio"], o["net_psnr"],
            "%s %s (%s)" % (o["zfp_mode"], o["zfp_psnr"], o["zfp_at"]) if o.get("zfp_psnr") else "not reached",
            "%s %s (%s)" % (o["sz3_mode"], fmt_db(f(o["sz3_psnr"])), sz3_ratio_text(o)) if o.get("sz3_psnr") else "-",
            "%s %s" % (o["best"], fmt_db(f(o["best_psnr"]))), o.get("delta_zfp_db", "-"),
            o["delta_db"].replace("-inf", "(lossless)")))
    md += ["", "Networks larger than their volume (ratio at most 1:1; raw storage wins there) are left out of the "
           "table and counted below.", "", "Where the network loses (every network ratio above 1:1):", ""]
    by_vol = defaultdict(list)
    for o in out:
        by_vol[(o["volume"], o["dims"])].append(o)
    md += [loses_line(v, d, rs) for (v, d), rs in sorted(by_vol.items())]
    seeds = seed_rows(rows, legacy_seeds(args.legacy_seeds) if args.legacy_seeds else [])
    if seeds:
        md += ["", "## PyTorch reference over seeds", ""] + torch_table(rows, seeds)
    md += bar_rows(rows, set(by_vol))
    write_md(args.md, "\n".join(md) + "\n")
    if args.readme:
        write_md(args.readme, "\n".join(readme_rows(out, args.readme_min_ratio)) + "\n")
    print("\n".join(md))
    if args.plots:
        import tradeoff_plot
        tradeoff_plot.plot_rd(rows, seeds, args.plots)


if __name__ == "__main__":
    main()
