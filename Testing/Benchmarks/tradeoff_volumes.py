#!/usr/bin/env python3
"""Procedural test volumes for the rate-distortion table (issue 25), seeded and deterministic, written as
NAME_<n>_float.nhdr + .raw (float32, little endian) into a folder (never commit them: 512^3 is 512 MiB each).

  tradeoff_volumes.py OUT_DIR [--size 512] [--seed 1] [--only mlnoise,rmmixing]
  tradeoff_volumes.py --self-test DIR      (CI: two runs at 40^3 give the same bytes; values finite, with structure)

- mlnoise: the Marschner-Lobb test signal (f_M = 6, alpha = 0.25, on [-1, 1]^3) plus multi-scale value noise
  (lattices of 4 to n/2 cells, smoothstep-interpolated, amplitude halving per octave; 0.35 of the signal's range).
- rmmixing: a Richtmyer-Meshkov-like mixing layer: heavy fluid (density 3) over light (1) across a multi-mode
  perturbed interface (modes up to 16 per side, amplitude ~ 1/k), folded inside a mixing zone by ridged multi-scale
  noise (bubbles and spikes), the interface about 1.5 voxels wide, a rippled transmitted shock (density x 1.3)
  above the layer, and +-2% multi-scale fluctuations everywhere (acoustic waves: no region exactly constant).
Every value comes from numpy's default_rng(seed) lattices and closed-form functions, evaluated in z-slabs (a 512^3
volume needs about 1 GiB while it is written). numpy only, so the GPU machine can generate them itself."""
import argparse
import filecmp
import hashlib
import os
import sys

import numpy as np

SLAB = 16


def smoothstep(f):
    return f * f * (3.0 - 2.0 * f)


def lerp_axis(lattice, u, axis):
    """Interpolate `lattice` along `axis` at lattice coordinates u (smoothstep weights)."""
    cells = lattice.shape[axis] - 1
    i0 = np.minimum(np.floor(u).astype(np.int64), cells - 1)
    f = smoothstep((u - i0).astype(np.float32))
    shape = [1] * lattice.ndim
    shape[axis] = -1
    f = f.reshape(shape)
    a = np.take(lattice, i0, axis=axis)
    return a + (np.take(lattice, i0 + 1, axis=axis) - a) * f


class ValueNoise:
    """Sum of octaves of smoothstep value noise over [0, 1]^3: lattices of 4, 8, .. `finest` cells, amplitude
    `persistence`^octave, normalised to about [-1, 1]. ridged: 1 - 2|noise| per octave (sharp creases)."""

    def __init__(self, rng, finest, persistence=0.5, ridged=False):
        self.lattices, self.amplitudes, self.ridged = [], [], ridged
        cells = 4
        while cells <= finest:
            self.lattices.append(rng.random((cells + 1,) * 3, dtype=np.float32) * 2.0 - 1.0)
            self.amplitudes.append(persistence ** len(self.amplitudes))
            cells *= 2
        self.norm = 1.0 / sum(self.amplitudes)

    def slab(self, tz, ty, tx):
        """Noise at the grid tz x ty x tx (coordinates in [0, 1])."""
        out = np.zeros((len(tz), len(ty), len(tx)), np.float32)
        for lattice, amplitude in zip(self.lattices, self.amplitudes):
            cells = lattice.shape[0] - 1
            lo = int(min(np.floor(tz.min() * cells), cells - 1))
            hi = int(min(np.floor(tz.max() * cells), cells - 1)) + 2
            v = lerp_axis(lattice[lo:hi], tz * cells - lo, 0)
            v = lerp_axis(v, ty * cells, 1)
            v = lerp_axis(v, tx * cells, 2)
            out += amplitude * ((1.0 - 2.0 * np.abs(v)) if self.ridged else v)
        return out * self.norm


def marschner_lobb(tz, ty, tx, fm=6.0, alpha=0.25):
    z, y, x = [2.0 * t - 1.0 for t in (tz, ty, tx)]
    r = np.sqrt(x[None, None, :] ** 2 + y[None, :, None] ** 2)
    rho = np.cos(2.0 * np.pi * fm * np.cos(np.pi * r / 2.0))
    return ((1.0 - np.sin(np.pi * z[:, None, None] / 2.0) + alpha * (1.0 + rho)) / (2.0 * (1.0 + alpha))).astype(
        np.float32)


class MlNoise:
    def __init__(self, n, seed):
        self.noise = ValueNoise(np.random.default_rng([seed, 1]), max(4, n // 2))

    def slab(self, tz, ty, tx):
        return marschner_lobb(tz, ty, tx) + 0.35 * self.noise.slab(tz, ty, tx)


class RmMixing:
    def __init__(self, n, seed):
        rng = np.random.default_rng([seed, 2])
        self.modes = [(kx, ky, 0.035 / np.hypot(kx, ky), rng.uniform(0, 2 * np.pi))
                      for kx in range(-16, 17) for ky in range(0, 17) if (kx, ky) != (0, 0) and rng.random() < 0.5]
        self.turbulence = ValueNoise(rng, max(4, n // 2), persistence=0.6, ridged=True)
        self.width_noise = ValueNoise(rng, 16)
        self.shock_noise = ValueNoise(rng, 32)
        self.acoustic = ValueNoise(rng, max(4, n // 4), persistence=0.7)
        self.delta = 1.5 / n  # the interface's width: about 1.5 voxels

    def surface(self, ty, tx):
        """The interface's height and the mixing zone's width over (y, x): computed once per grid."""
        if getattr(self, "grid", None) is None or self.grid[0] is not ty or self.grid[1] is not tx:
            h = np.full((len(ty), len(tx)), 0.45, np.float32)
            for kx, ky, a, phase in self.modes:
                h += (a * np.cos(2 * np.pi * (kx * tx[None, :] + ky * ty[:, None]) + phase)).astype(np.float32)
            width = 0.09 * (1.0 + 0.6 * self.width_noise.slab(np.array([0.5]), ty, tx)[0])
            self.grid, self.h, self.width = (ty, tx), h, width
        return self.h, self.width

    def slab(self, tz, ty, tx):
        h, width = self.surface(ty, tx)
        dz = tz[:, None, None] - h[None]
        envelope = np.exp(-(dz / width[None]) ** 2)
        phi = dz + 2.2 * width[None] * envelope * self.turbulence.slab(tz, ty, tx)
        heavy = 0.5 * (1.0 + np.tanh(phi / self.delta))
        density = 1.0 + 2.0 * heavy
        shock = 0.8 + 0.02 * self.shock_noise.slab(tz, ty, tx)
        density *= 1.0 + 0.3 * 0.5 * (1.0 + np.tanh((shock - tz[:, None, None]) / self.delta))
        # Acoustic waves and the flow's small-scale fluctuations: +-2% everywhere (no region is exactly constant, as
        # in a simulation's output).
        density *= 1.0 + 0.02 * self.acoustic.slab(tz, ty, tx)
        return density.astype(np.float32)


FIELDS = {"mlnoise": MlNoise, "rmmixing": RmMixing}


def write(folder, name, n, seed):
    """Write NAME_<n>_float.nhdr + .raw, slab by slab; prints the raw file's sha256; returns the .nhdr path."""
    os.makedirs(folder, exist_ok=True)
    field = FIELDS[name](n, seed)
    t = np.linspace(0.0, 1.0, n)
    stem = os.path.join(folder, "%s_%d_float" % (name, n))
    digest = hashlib.sha256()
    with open(stem + ".raw", "wb") as f:
        for k in range(0, n, SLAB):
            data = field.slab(t[k:k + SLAB], t, t).astype("<f4").tobytes()
            digest.update(data)
            f.write(data)
    print("sha256 %s  %s" % (digest.hexdigest(), os.path.basename(stem) + ".raw"), flush=True)
    with open(stem + ".nhdr", "w") as f:
        f.write("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nendian: little\nencoding: raw\n"
                "data file: %s\n" % (n, n, n, os.path.basename(stem) + ".raw"))
    return stem + ".nhdr"


def self_test(folder, n=40):
    """Two runs write the same bytes; every value finite; each field has structure (spread, no constant slab)."""
    a = [write(os.path.join(folder, "a"), name, n, 3) for name in FIELDS]
    b = [write(os.path.join(folder, "b"), name, n, 3) for name in FIELDS]
    c = write(os.path.join(folder, "c"), "mlnoise", n, 4)
    bad = []
    for pa, pb in zip(a, b):
        raw_a, raw_b = pa[:-5] + ".raw", pb[:-5] + ".raw"
        if not filecmp.cmp(raw_a, raw_b, shallow=False):
            bad.append("%s differs between two runs of the same seed" % os.path.basename(raw_a))
        v = np.fromfile(raw_a, "<f4").reshape(n, n, n)
        if v.size != n ** 3 or not np.all(np.isfinite(v)):
            bad.append("%s: non-finite values" % os.path.basename(raw_a))
        elif float(v.std()) < 0.05 * float(v.max() - v.min()) or min(float(s.std()) for s in v) <= 0.0:
            bad.append("%s: no structure (std %.3g, range %.3g)" % (os.path.basename(raw_a), v.std(), np.ptp(v)))
    if filecmp.cmp(a[0][:-5] + ".raw", c[:-5] + ".raw", shallow=False):
        bad.append("mlnoise: seeds 3 and 4 give the same volume")
    if bad:
        raise SystemExit("self-test: " + "; ".join(bad))
    print("self-test: %s at %d^3: deterministic, finite, structured; another seed differs" % (", ".join(FIELDS), n))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--only", default=",".join(FIELDS))
    p.add_argument("--self-test", action="store_true")
    args = p.parse_args()
    if args.self_test:
        return self_test(args.out)
    for name in args.only.split(","):
        print(write(args.out, name, args.size, args.seed), flush=True)


if __name__ == "__main__":
    sys.exit(main())
