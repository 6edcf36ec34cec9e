#!/usr/bin/env python3
"""Engine against the PyTorch reference over seeds (run_tradeoff_gpu.sh `seeds`): per volume and step mark, the mean,
the spread (max - min) and the per-seed PSNR of each engine schedule and of the reference, and the differences of the
means. usage: summarize_seeds.py seeds_engine.log seeds_torch.log > seeds.md"""
import json
import statistics
import sys
from collections import defaultdict


def engine_runs(path):
    """{((volume, log2T), variant): {steps: [psnr per seed]}} from 'VARIANT name RESULT {...}' lines."""
    runs = defaultdict(lambda: defaultdict(list))
    for line in open(path):
        if line.startswith("VARIANT ") and " RESULT " in line:
            name, payload = line.split(" RESULT ", 1)
            r = json.loads(payload)
            runs[((r["name"], r["log2T"]), name.split()[1])][r["steps"]].append(r["psnr"] if r["psnr"] is not None else float("nan"))
    return runs


def torch_runs(path):
    """{(volume, log2T): {steps: [psnr per seed]}} and {(volume, log2T): [wall s to the last mark]} from 'SEED n RESULT {...}' lines."""
    runs = defaultdict(lambda: defaultdict(list))
    times = defaultdict(list)
    for line in open(path):
        if line.startswith("SEED ") and " RESULT " in line:
            r = json.loads(line.split(" RESULT ", 1)[1])
            name = (r["name"], r["log2T"])
            for s, t, p in r["curve"]:
                runs[name][s].append(p)
            times[name].append(r["curve"][-1][1])
    return runs, times


def stats(v):
    return statistics.mean(v), max(v) - min(v)


def main(engine_log, torch_log):
    eng = engine_runs(engine_log)
    ref, ref_times = torch_runs(torch_log)
    variants = sorted({k[1] for k in eng}, key=lambda n: (n != "step", n))
    print("| volume | table | steps | PyTorch mean (spread, n) | " + " | ".join(f"engine {v}: mean (spread, n), minus PyTorch"
                                                            for v in variants) + " |")
    print("|---|---|---|---|" + "---|" * len(variants))
    for vol in sorted(ref):
        name = vol
        for steps in sorted(ref[vol]):
            r = ref[vol][steps]
            rm, rs = stats(r)
            cells = []
            for v in variants:
                e = eng.get((name, v), {}).get(steps)
                if not e:
                    cells.append("-")
                    continue
                em, es = stats(e)
                cells.append(f"{em:.2f} ({es:.2f}, {len(e)}), {em - rm:+.2f}")
            print(f"| {name[0]} | 2^{name[1]} | {steps} | {rm:.2f} ({rs:.2f}, {len(r)}) | " + " | ".join(cells) + " |")
    print()
    print("Per-seed PSNR at the last mark:")
    print()
    for vol in sorted(ref):
        last = max(ref[vol])
        line = [f"PyTorch {', '.join(f'{p:.2f}' for p in ref[vol][last])}"]
        for v in variants:
            e = eng.get((vol, v), {}).get(last)
            if e:
                line.append(f"engine {v} {', '.join(f'{p:.2f}' for p in e)}")
        print(f"- {vol[0]} 2^{vol[1]} @{last}: " + "; ".join(line) + f" (PyTorch wall s: {statistics.mean(ref_times[vol]):.2f})")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
