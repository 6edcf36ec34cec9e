"""A procedural volume with structure at many scales, written as a raw file with an NRRD detached header (.nhdr) in
z-slabs: never more than one slab in memory, whatever the size (issue 22's out-of-core tests and benchmark).

The field on [-1, 1]^3: the Marschner-Lobb test signal (f_M = 6, alpha = 0.25; range 0..1) plus band-limited noise,
separable cosine products at 2, 4, 8, 16 and 32 cycles over the domain with amplitude halving per octave (fixed seed).
Every grid of the family samples the same function: a small one fits in memory, a large one does not, and both have
the same content (the finest noise has 8 samples a cycle on a 256^3 grid).

  python3 ooc_procedural.py OUT.nhdr NX NY NZ [--type float32|float64|uint8|int16] [--workers N] [--slab-mib 64]
  python3 ooc_procedural.py OUT.nhdr 128 128 128 --npy small.npy    # also the values as .npy (small grids only)

As a module: write_volume(path, dims, type_name) and values(dims, z0, z1) (the slab z0..z1 in z, y, x order).
"""
import argparse
import math
import os
import sys
import time

import numpy as np

OCTAVES = (2, 4, 8, 16, 32)  # cycles over the domain [-1, 1]
TERMS_PER_OCTAVE = 2
NOISE_AMPLITUDE = 0.12       # of the coarsest octave; halves per octave
TYPES = {"float32": (np.float32, "float"), "float64": (np.float64, "double"), "uint8": (np.uint8, "uchar"),
         "int16": (np.int16, "short")}
# Integer types: the field (about -0.25 .. 1.25) scaled into the type's range.
SCALE = {"float32": (1.0, 0.0), "float64": (1.0, 0.0), "uint8": (160.0, 48.0), "int16": (20000.0, -6000.0)}


def _noise_terms():
    rng = np.random.default_rng(22)
    terms = []
    for octave, cycles in enumerate(OCTAVES):
        for _ in range(TERMS_PER_OCTAVE):
            k = cycles * (1.0 + 0.15 * rng.uniform(-1, 1, 3))  # per axis, jittered
            phase = rng.uniform(0, 2 * math.pi, 3)
            terms.append((NOISE_AMPLITUDE * 0.5 ** octave / TERMS_PER_OCTAVE ** 0.5, k, phase))
    return terms


TERMS = _noise_terms()


def _axis(n):
    return np.linspace(-1.0, 1.0, n) if n > 1 else np.zeros(1)


class Planes:
    """What a slab needs, computed once per grid: the Marschner-Lobb radial plane and each noise term's x-y plane."""

    def __init__(self, dims):
        nx, ny, nz = dims
        x, y = _axis(nx), _axis(ny)
        r = np.sqrt(x[None, :] ** 2 + y[:, None] ** 2)
        self.radial = (0.25 * (1.0 + np.cos(2 * math.pi * 6.0 * np.cos(math.pi * r / 2)))).astype(np.float32)
        self.z = _axis(nz)
        self.planes = [(a * np.outer(np.cos(math.pi * k[1] * y + p[1]), np.cos(math.pi * k[0] * x + p[0]))
                        ).astype(np.float32) for a, k, p in TERMS]


def values(dims, z0, z1, planes=None):
    """The field on slab z0..z1 of the grid `dims` (x, y, z), float32 in (z, y, x) order."""
    planes = planes or Planes(dims)
    z = planes.z[z0:z1]
    out = np.empty((z1 - z0,) + planes.radial.shape, dtype=np.float32)
    for i, zi in enumerate(z):
        slab = out[i]
        np.add(planes.radial, np.float32(1.0 - math.sin(math.pi * zi / 2)), out=slab)
        slab *= np.float32(1.0 / 2.5)  # 2 (1 + alpha)
        for (_, k, p), plane in zip(TERMS, planes.planes):
            slab += plane * np.float32(math.cos(math.pi * k[2] * zi + p[2]))
    return out


def convert(slab, type_name):
    scale, offset = SCALE[type_name]
    if type_name.startswith("float"):
        return slab.astype(TYPES[type_name][0], copy=False)
    info = np.iinfo(TYPES[type_name][0])
    return np.clip(np.rint(slab * scale + offset), info.min, info.max).astype(TYPES[type_name][0])


def header_text(dims, type_name, raw_name):
    spacing = [2.0 / max(1, n - 1) for n in dims]
    return ("NRRD0004\ntype: %s\ndimension: 3\nsizes: %d %d %d\nspace dimension: 3\n"
            "space directions: (%r,0,0) (0,%r,0) (0,0,%r)\nspace origin: (-1,-1,-1)\nencoding: raw\n"
            "endian: little\ndata file: %s\n" % ((TYPES[type_name][1],) + tuple(dims) + tuple(spacing) + (raw_name,)))


def _write_slabs(raw_path, dims, type_name, z_ranges):
    planes = Planes(dims)
    item = np.dtype(TYPES[type_name][0]).itemsize
    plane_bytes = dims[0] * dims[1] * item
    fd = os.open(raw_path, os.O_WRONLY)
    try:
        for z0, z1 in z_ranges:
            data = convert(values(dims, z0, z1, planes), type_name).tobytes()
            written = 0
            while written < len(data):
                written += os.pwrite(fd, data[written:], z0 * plane_bytes + written)
    finally:
        os.close(fd)


def write_volume(path, dims, type_name="float32", workers=1, slab_mib=64):
    """Writes `path` (.nhdr) and its raw file beside it; returns the raw file's path. Memory: a slab per worker."""
    raw_path = os.path.splitext(path)[0] + ".raw"
    item = np.dtype(TYPES[type_name][0]).itemsize
    with open(raw_path, "wb") as f:
        f.truncate(dims[0] * dims[1] * dims[2] * item)
    per_slab = max(1, int(slab_mib * 2 ** 20 // (dims[0] * dims[1] * 4)))
    slabs = [(z, min(dims[2], z + per_slab)) for z in range(0, dims[2], per_slab)]
    if workers <= 1:
        _write_slabs(raw_path, dims, type_name, slabs)
    else:
        import multiprocessing
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            pool.starmap(_write_slabs, [(raw_path, dims, type_name, slabs[w::workers]) for w in range(workers)])
    with open(path, "w") as f:
        f.write(header_text(dims, type_name, os.path.basename(raw_path)))
    return raw_path


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("path")
    parser.add_argument("dims", type=int, nargs=3)
    parser.add_argument("--type", default="float32", choices=sorted(TYPES))
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--slab-mib", type=float, default=64)
    parser.add_argument("--npy", help="also save the values (z, y, x) as .npy (small grids)")
    args = parser.parse_args()
    start = time.time()
    raw = write_volume(args.path, args.dims, args.type, args.workers, args.slab_mib)
    if args.npy:
        np.save(args.npy, convert(values(args.dims, 0, args.dims[2]), args.type))
    print("wrote %s (%d bytes) in %.1f s" % (raw, os.path.getsize(raw), time.time() - start))
    return 0


if __name__ == "__main__":
    sys.exit(main())
