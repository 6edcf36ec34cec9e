#!/usr/bin/python3
"""Defaults against the data folder's volumes (issue 25, item 3): PSNR and ratio of the table size and storage the
automatic sizing picks, before and after, measured with `nvBench tradeoff` (the filter's network: 16x4 levels,
finest 2x the largest dimension, 64x4 MLP, batch 65536, L1, the annealed schedule of a run of known length).

  levers_defaults.py NVBENCH DATA_DIR [--steps=500] [--device=CPU] [--threads=2] [--only=name,..] [--out=FILE.jsonl]

Each case is a (volume, log2 table size) pair; both storages (fp16 and q8) come from one training. The cases are the
tables the old rule picks (the largest table for 10:1 in fp16, else 2^10) and the new one (the largest for 10:1 in
8-bit codes; a small input, where no table reaches the target, the quality-first size of
nv::chooseLog2TableSize's caller: Cuda/Core/Model.h qualityFirstLog2TableSize), plus the sizes around them.
Prints one RESULT line per case and storage (the nvBench JSON) and a table at the end.
"""
import json
import os
import subprocess
import sys

CASES = {
    # name: (file, [log2 table sizes])
    "nucleon": ("nucleon/nucleon_41x41x41_uint8.nhdr", [10, 14]),
    "bucky": ("bucky/bucky_32x32x32_uint8.nhdr", [10, 14, 15]),
    "neghip": ("neghip/neghip_66x66x66_uint8.nhdr", [10, 14, 18]),
    "headsq": ("headsq/headsq_64x64x93_int16.nhdr", [10, 13]),
    "ironprot": ("ironprot/ironProt_68x68x68_uint8.nhdr", [10, 14, 18]),
    "walnut": ("walnut/walnut_128x96x114_uint16.nhdr", [10, 11]),
    "stent": ("stent/stent_128x128x256_int16.nhdr", [12, 13]),
}


def option(name, default):
    for a in sys.argv[3:]:
        if a.startswith("--%s=" % name):
            return a.split("=", 1)[1]
    return default


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    bench, data = sys.argv[1], sys.argv[2]
    steps = option("steps", "500")
    device = option("device", "CPU")
    threads = option("threads", "2")
    only = option("only", "")
    names = only.split(",") if only else list(CASES)
    out = option("out", "")
    rows = []
    for name in names:
        path, tables = CASES[name]
        full = os.path.join(data, path)
        for log2t in tables:
            cmd = [bench, "tradeoff", device, full, str(log2t), steps, "--threads=" + threads, "--schedule=auto",
                   "--storage=both"]
            res = subprocess.run(cmd, capture_output=True, text=True, timeout=3600)
            for line in res.stdout.splitlines():
                if line.startswith("RESULT "):
                    r = json.loads(line[7:])
                    r["case"] = name
                    rows.append(r)
                    print(line, flush=True)
                    if out:
                        with open(out, "a") as f:
                            f.write(json.dumps(r) + "\n")
            if res.returncode != 0:
                print("FAILED %s 2^%d: %s" % (name, log2t, res.stderr[-2000:]), flush=True)
    print("\n| volume | log2T | storage | steps | PSNR dB | ratio | train s |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %d | %s | %d | %.2f | %.1f | %.0f |" % (r["case"], r["log2T"], r["storage"], r["steps"], r["psnr"],
                                                         r["ratio"], r["train_s"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
