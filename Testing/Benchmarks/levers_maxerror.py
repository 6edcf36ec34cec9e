#!/usr/bin/python3
"""The ratio cost of MaxError (the error-bounded mode, Cuda/Core/ErrorCorrections.h) on a real volume (issue 25,
item 4): trains the filter's network with `nvBench tradeoff` (--dump: the stored network's decoded grid, float32) and
counts, for bounds of a fraction of the range, the corrections the engine stores (the same rule: samples with |error| >
0.9 x bound, varint index steps and zig-zag varints of round(error / bound)) and their coded bytes: the two varint
streams' order-0 entropy plus a 260-byte table and 4-byte state each (what the engine's rANS coder reaches within about
1%), plus 40 bytes; then the ratio with and without them.

  levers_maxerror.py NVBENCH FILE.nhdr LOG2T STEPS [--storage=q8|fp16] [--threads=2] [--fractions=0.01,0.005,0.001]
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def read_nhdr(path):
    fields = {}
    with open(path) as f:
        for line in f:
            if ":" in line:
                k, v = line.split(":", 1)
                fields[k.strip()] = v.strip()
    types = {"uchar": np.uint8, "unsigned char": np.uint8, "uint8": np.uint8, "short": np.int16, "int16": np.int16,
             "ushort": np.uint16, "unsigned short": np.uint16, "uint16": np.uint16, "float": np.float32,
             "double": np.float64}
    raw = os.path.join(os.path.dirname(path), fields["data file"])
    return np.fromfile(raw, dtype=np.dtype(types[fields["type"]]).newbyteorder("<")).astype(np.float64)


def varint_stream(v):
    """The LEB128 bytes of every value of v (uint64), as one uint8 array (values in order)."""
    v = v.astype(np.uint64)
    parts, rest, more = [], v.copy(), np.ones(v.shape, dtype=bool)
    k = 0
    while more.any():
        byte = (rest & np.uint64(0x7F)).astype(np.uint8)
        nxt = rest >> np.uint64(7)
        cont = nxt > 0
        parts.append((k, np.nonzero(more)[0], (byte | (cont.astype(np.uint8) << 7))[more]))
        more = more & cont
        rest = nxt
        k += 1
    # Interleave: value i's bytes in order; order by (value index, byte position).
    idx = np.concatenate([p[1] for p in parts])
    pos = np.concatenate([np.full(p[1].size, p[0]) for p in parts])
    val = np.concatenate([p[2] for p in parts])
    order = np.lexsort((pos, idx))
    return val[order]


def coded_bytes(stream):
    if stream.size == 0:
        return 8
    counts = np.bincount(stream, minlength=256).astype(np.float64)
    p = counts[counts > 0] / stream.size
    return 8 + int(np.ceil(-(counts[counts > 0] * np.log2(p)).sum() / 8)) + 260 + 4


def correction_bytes(source, decoded, bound):
    error = source - decoded
    idx = np.nonzero(np.abs(error) > 0.9 * bound)[0]
    if idx.size == 0:
        return 0, 40
    steps = np.rint(error[idx] / bound).astype(np.int64)
    zig = (steps << 1) ^ (steps >> 63)
    deltas = np.diff(np.concatenate([[-1], idx]))
    return idx.size, 24 + coded_bytes(varint_stream(deltas)) + coded_bytes(varint_stream(zig))


def main():
    if len(sys.argv) < 5:
        print(__doc__)
        return 2
    bench, path, log2t, steps = sys.argv[1:5]
    opts = dict(a[2:].split("=", 1) for a in sys.argv[5:] if a.startswith("--"))
    storage = opts.get("storage", "q8")
    fractions = [float(x) for x in opts.get("fractions", "0.01,0.005,0.001").split(",")]
    source = read_nhdr(path)
    with tempfile.TemporaryDirectory() as dump:
        cmd = [bench, "tradeoff", "CPU", path, log2t, steps, "--threads=" + opts.get("threads", "2"),
               "--schedule=auto", "--storage=" + storage, "--dump=" + dump]
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=7200)
        result = [json.loads(l[7:]) for l in res.stdout.splitlines() if l.startswith("RESULT ")][-1]
        decoded = np.fromfile(result["dump"], dtype=np.float32).astype(np.float64)
    span = source.max() - source.min()
    print("%s 2^%s %s, %s steps: PSNR %.2f dB, max error %.4g (%.4f of the range), ratio %.2f:1 (%d bytes)"
          % (result["name"], log2t, storage, steps, result["psnr"], result["max_error"], result["max_error"] / span,
             result["ratio"], result["model_bytes"]))
    print("| bound (of the range) | corrected voxels | share | list bytes | bytes each | ratio |")
    print("|---|---|---|---|---|---|")
    for f in fractions:
        count, bytes_ = correction_bytes(source, decoded, f * span)
        ratio = result["source_bytes"] / (result["model_bytes"] + bytes_)
        print("| %.4g (%g) | %d | %.2f%% | %d | %.2f | %.2f:1 |" % (f * span, f, count, 100.0 * count / source.size,
                                                                    bytes_, (bytes_ - 40) / max(count, 1), ratio))
    return 0


if __name__ == "__main__":
    sys.exit(main())
