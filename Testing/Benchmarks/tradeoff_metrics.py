"""Shared pieces of the run-time-versus-error harness (tradeoff.py): volumes, error metrics, a small
emission-absorption renderer for the image metric, and SSIM. numpy only, so it runs on the GPU machine as well."""
import csv
import math
import os

import numpy as np

NHDR_TYPES = {"uchar": np.uint8, "unsigned char": np.uint8, "uint8": np.uint8, "char": np.int8, "int8": np.int8,
              "short": np.int16, "int16": np.int16, "ushort": np.uint16, "unsigned short": np.uint16,
              "uint16": np.uint16, "int": np.int32, "int32": np.int32, "uint": np.uint32, "uint32": np.uint32,
              "float": np.float32, "double": np.float64}


def load_nhdr(path):
    """The raw array of a NRRD header with a detached data file, shape (nz, ny, nx), in its own type."""
    h = {}
    for line in open(path):
        if ":" in line and not line.startswith("#"):
            k, v = line.split(":", 1)
            h[k.strip()] = v.strip()
    nx, ny, nz = [int(v) for v in h["sizes"].split()]
    dt = np.dtype(NHDR_TYPES[h["type"]]).newbyteorder("<" if h.get("endian", "little") == "little" else ">")
    data = os.path.join(os.path.dirname(path), h["data file"])
    return np.fromfile(data, dt).reshape(nz, ny, nx)


def write_nhdr(path, array):
    """Write a (nz, ny, nx) array as NAME.nhdr + NAME.raw (little endian)."""
    names = {np.dtype(np.uint8): "uchar", np.dtype(np.int16): "short", np.dtype(np.uint16): "ushort",
             np.dtype(np.float32): "float", np.dtype(np.float64): "double"}
    raw = os.path.splitext(path)[0] + ".raw"
    array.astype(array.dtype.newbyteorder("<")).tofile(raw)
    nz, ny, nx = array.shape
    with open(path, "w") as f:
        f.write("NRRD0004\ntype: %s\ndimension: 3\nsizes: %d %d %d\nendian: little\nencoding: raw\ndata file: %s\n"
                % (names[array.dtype], nx, ny, nz, os.path.basename(raw)))


def errors(original, decoded, slab=32):
    """(PSNR over every voxel with values normalised by the original's range, max abs error in source units).
    A non-finite decoded value gives (nan, inf): never a good score. Summed over slabs of the first axis in float64,
    so that a 512^3 volume needs no full-size float64 copies."""
    lo, hi = float(original.min()), float(original.max())
    rng = hi - lo if hi > lo else 1.0
    sq, worst = 0.0, 0.0
    for k in range(0, original.shape[0], slab):
        d = decoded[k:k + slab].astype(np.float64)
        if not np.all(np.isfinite(d)):
            return float("nan"), float("inf")
        diff = d - original[k:k + slab].astype(np.float64)
        sq += float(np.sum((diff / rng) ** 2))
        worst = max(worst, float(np.max(np.abs(diff))))
    mse = sq / original.size
    psnr = -10.0 * math.log10(mse) if mse > 0 else float("inf")
    return psnr, worst


def render(volume, lo, hi, threshold, axis):
    """Orthographic emission-absorption image of `volume` along `axis` (front to back, one sample per voxel):
    values normalised by [lo, hi]; transparent up to `threshold` (normalised), then opacity and emission grow
    linearly. Returns a float64 image in [0, 1]."""
    v = np.moveaxis(volume.astype(np.float64), axis, 0)
    v = np.clip((v - lo) / (hi - lo if hi > lo else 1.0), 0.0, 1.0)
    color = np.zeros(v.shape[1:])
    trans = np.ones(v.shape[1:])
    for s in v:
        a = np.clip((s - threshold) / max(1.0 - threshold, 1e-6), 0.0, 1.0) * 0.2
        color += trans * a * s
        trans *= 1.0 - a
    return color


def _blur(image, sigma=1.5, radius=5):
    x = np.arange(-radius, radius + 1)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    k /= k.sum()
    p = np.pad(image, radius, mode="reflect")
    p = np.apply_along_axis(lambda r: np.convolve(r, k, mode="valid"), 0, p)
    return np.apply_along_axis(lambda r: np.convolve(r, k, mode="valid"), 1, p)


def ssim(a, b, data_range=1.0):
    """Mean SSIM (Wang et al. 2004: Gaussian window sigma 1.5, K1 0.01, K2 0.03) of two images."""
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    ma, mb = _blur(a), _blur(b)
    va = _blur(a * a) - ma * ma
    vb = _blur(b * b) - mb * mb
    cov = _blur(a * b) - ma * mb
    s = ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2))
    return float(np.mean(s))


class ImageMetric:
    """SSIM between renderings of the original and of a reconstruction, averaged over two views (along z and y).
    The transfer function is fixed per volume: transparent up to the original's 75th percentile."""

    def __init__(self, original):
        o = original.astype(np.float64)
        self.lo, self.hi = float(o.min()), float(o.max())
        rng = self.hi - self.lo if self.hi > self.lo else 1.0
        self.threshold = float(np.percentile((o - self.lo) / rng, 75))
        self.reference = [render(o, self.lo, self.hi, self.threshold, axis) for axis in (0, 1)]

    def __call__(self, decoded):
        d = decoded.astype(np.float64)
        if not np.all(np.isfinite(d)):
            return float("nan")
        images = [render(d, self.lo, self.hi, self.threshold, axis) for axis in (0, 1)]
        rng = max(max(float(r.max()) for r in self.reference), 1e-12)
        return float(np.mean([ssim(r / rng, i / rng) for r, i in zip(self.reference, images)]))


def synthetic_volumes(folder, n=32):
    """Two small volumes with structure for the CI run of the harness: a Marschner-Lobb field (float32) and
    multi-octave value noise quantised to uint8. Returns their .nhdr paths."""
    os.makedirs(folder, exist_ok=True)
    t = np.linspace(-1.0, 1.0, n)
    z, y, x = np.meshgrid(t, t, t, indexing="ij")
    r = np.sqrt(x * x + y * y)
    ml = (1 - np.sin(np.pi * z / 2) + 0.25 * (1 + np.cos(2 * np.pi * 6 * np.cos(np.pi * r / 2)))) / 2.5
    rng = np.random.default_rng(7)
    noise = np.zeros((n, n, n))
    for octave in range(4):
        c = 2 ** (octave + 2)
        coarse = rng.random((c + 1, c + 1, c + 1))
        idx = np.linspace(0, c, n)
        i0 = np.minimum(idx.astype(int), c - 1)
        f = idx - i0
        g = coarse
        for ax in range(3):
            g = np.take(g, i0, axis=ax) * (1 - f.reshape([-1 if k == ax else 1 for k in range(3)])) + \
                np.take(g, i0 + 1, axis=ax) * f.reshape([-1 if k == ax else 1 for k in range(3)])
        noise += g / 2 ** octave
    noise = (255 * (noise - noise.min()) / (noise.max() - noise.min())).astype(np.uint8)
    paths = [os.path.join(folder, "marschnerlobb_%d_float.nhdr" % n), os.path.join(folder, "noise_%d_uint8.nhdr" % n)]
    write_nhdr(paths[0], ml.astype(np.float32))
    write_nhdr(paths[1], noise)
    return paths


def number(value):
    """A CSV cell as a float (nan when empty or not a number)."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def load_rows(paths):
    """Every row of the CSV files, in order."""
    rows = []
    for path in paths:
        with open(path) as f:
            rows += list(csv.DictReader(f))
    return rows
