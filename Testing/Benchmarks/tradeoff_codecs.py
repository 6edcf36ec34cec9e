"""The competitors of the rate-distortion table (tradeoff.py compressors), each in the modes an expert would try:
ZFP fixed-accuracy (tolerance swept until the ratio passes the largest target), fixed-precision and fixed-rate; SZ3
in its ABS, REL and PSNR error-bound modes with the bound found by bisection so that the ratio lands within 2% of
each target ratio (the network's ratios).

SZ3's ratio is not monotone in its bound (stent: 9.81 / 9.22 / 8.73 / 10.78:1 for growing bounds), so the bisection
first evaluates a grid of bounds, takes every pair of neighbours whose ratios bracket the target, and bisects inside
the first (tightest-bound) bracket until the ratio is within the tolerance; a bracket whose ratio jumps over the
target (the stream size is a step function of the bound) is given up after MAX_BISECT evaluations and the next one is
tried. The result is the evaluated bound whose ratio is closest to the target, with the achieved ratio, so a row
that missed says so (ratio outside 2% of target_ratio). A target below every bound's ratio (SZ3 near-lossless already
compresses more) gives the row of the mode's smallest ratio, marked "floor". numpy, zfpy and pysz only."""
import math
import time

import numpy as np

TOLERANCE = 0.02  # the SZ3 bisection's goal: |ratio / target - 1| <= 2%
MAX_BISECT = 24
SZ3_MODES = ("abs", "rel", "psnr")
ZFP_PRECISIONS = (1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 18, 20, 24, 28)
ZFP_MAX_TOLERANCE = 1e4  # x range: the fixed-accuracy sweep's end when no target stops it earlier
ZFP_MIN_RATE = 0.25  # zfpy 1.0 overruns its buffer below about 9 bits per 4^3 block: lower rates are not run


class Encoded:
    """One compressed stream: its size, the times, and (decoded on demand) the reconstruction."""

    def __init__(self, stream_bytes, compress_s, decode):
        self.stream_bytes = stream_bytes
        self.compress_s = compress_s
        self._decode = decode

    def decode(self):
        t0 = time.perf_counter()
        d = self._decode()
        return d, time.perf_counter() - t0


def zfp_encode(values, **mode):
    import zfpy
    t0 = time.perf_counter()
    c = zfpy.compress_numpy(values, **mode)
    t = time.perf_counter() - t0
    return Encoded(len(c), t, lambda: zfpy.decompress_numpy(c))


def sz3_encode(values, mode, bound):
    """SZ3 in `mode` (abs: absolute bound in source units, rel: relative to the value range, psnr: target PSNR dB)."""
    from pysz import sz, szConfig, szErrorBoundMode
    conf = szConfig()
    if mode == "abs":
        conf.errorBoundMode, conf.absErrorBound = szErrorBoundMode.ABS, bound
    elif mode == "rel":
        conf.errorBoundMode, conf.relErrorBound = szErrorBoundMode.REL, bound
    else:
        conf.errorBoundMode, conf.psnrErrorBound = szErrorBoundMode.PSNR, bound
    t0 = time.perf_counter()
    c, _ = sz.compress(values, conf)
    t = time.perf_counter() - t0
    return Encoded(c.nbytes, t, lambda: sz.decompress(c, np.float32, values.shape)[0].reshape(values.shape))


def zfp_accuracy(values, source_bytes, value_range, largest_target, start=1e-5, smallest_target=None):
    """Fixed-accuracy tolerances (factor 2 apart, from `start` x range) until the ratio passes `largest_target` (or the
    tolerance reaches ZFP_MAX_TOLERANCE x range); first down from `start` while the ratio is still above
    `smallest_target`. ZFP's errors stay far below its tolerance (a 32^3 field at a tolerance of 2.6 x range still
    decodes at 29 dB), so the sweep goes well past the range. Yields (setting, Encoded)."""
    def at(rel):
        return "tolerance %.3g x range" % rel, zfp_encode(values, tolerance=rel * value_range)

    first = at(start)
    yield first
    rel, ratio = start, source_bytes / first[1].stream_bytes
    while smallest_target and ratio > smallest_target and rel > 1e-9:
        rel /= 2.0
        row = at(rel)
        ratio = source_bytes / row[1].stream_bytes
        yield row
    rel, ratio = start, source_bytes / first[1].stream_bytes
    while ratio <= largest_target and rel * 2.0 <= ZFP_MAX_TOLERANCE:
        rel *= 2.0
        row = at(rel)
        ratio = source_bytes / row[1].stream_bytes
        yield row


def zfp_precision(values, source_bytes, largest_target, most=32, smallest_target=None):
    """Fixed precision from `most` bit planes down to 1 (the ratio grows as the precision falls), stopping below the
    first precision whose ratio passes `largest_target`; then up from `most` while the ratio is still above
    `smallest_target`."""
    ratios = {}
    for p in sorted((p for p in ZFP_PRECISIONS if p <= most), reverse=True):
        e = zfp_encode(values, precision=p)
        ratios[p] = source_bytes / e.stream_bytes
        yield "precision %d" % p, e
        if ratios[p] > largest_target:
            break
    if smallest_target and ratios and ratios[max(ratios)] > smallest_target:
        for p in sorted(p for p in ZFP_PRECISIONS if p > most):
            e = zfp_encode(values, precision=p)
            yield "precision %d" % p, e
            if source_bytes / e.stream_bytes <= smallest_target:
                break


def zfp_rate(values, source_bits, ratios):
    """Fixed rate at each ratio (bits per value = source bits / ratio), rates below ZFP_MIN_RATE skipped."""
    for ratio in sorted(set(ratios)):
        rate = source_bits / ratio
        if rate < ZFP_MIN_RATE:
            continue
        yield "rate %.4g bits" % rate, zfp_encode(values, rate=rate)


class Sz3Search:
    """Ratio as a function of one SZ3 mode's parameter, evaluated lazily and cached. The parameter is searched as
    `x` where the ratio grows with x: log10 of the bound (abs, rel) or minus the target PSNR (psnr)."""

    def __init__(self, values, source_bytes, value_range, mode, coarse=False):
        self.values, self.source_bytes, self.mode = values, source_bytes, mode
        # coarse (512^3 volumes, where one evaluation takes seconds): fewer, wider steps from 1e-6 x range / 130 dB
        if mode == "psnr":
            self.grid = list(np.arange(-130.0, -4.9, 10.0) if coarse else np.arange(-180.0, -4.9, 2.5))
        else:
            top = math.log10(value_range) if mode == "abs" else 0.0
            self.grid = list(np.arange(top - 6.0, top + 0.01, 0.5) if coarse else
                             np.arange(top - 9.0, top + 0.01, 0.25))
        self.cache = {}

    def bound(self, x):
        return -x if self.mode == "psnr" else 10.0 ** x

    def setting(self, x):
        return ("psnr %.4g dB" % self.bound(x)) if self.mode == "psnr" else ("%s %.4g" % (self.mode, self.bound(x)))

    def ratio(self, x):
        if x not in self.cache:  # the ratio only: the streams of a 512^3 volume's search would not fit in memory
            self.cache[x] = self.source_bytes / sz3_encode(self.values, self.mode, self.bound(x)).stream_bytes
        return self.cache[x]

    def encoded(self, x):
        """The stream at x, encoded again (deterministic: the same size as in the search)."""
        return sz3_encode(self.values, self.mode, self.bound(x))

    def find(self, target):
        """The x whose ratio is closest to `target` after bracketing and bisection (see the module's text)."""
        ratios = [self.ratio(x) for x in self.grid]
        if min(ratios) > target * (1.0 + TOLERANCE):
            return min(self.grid, key=self.ratio)  # the floor: every bound compresses more than the target asks
        brackets = [(a, b) for a, b, ra, rb in zip(self.grid, self.grid[1:], ratios, ratios[1:])
                    if (ra - target) * (rb - target) <= 0]
        for lo, hi in brackets:
            if self._within(lo, target) or self._within(hi, target):
                break
            for _ in range(MAX_BISECT):
                mid = 0.5 * (lo + hi)
                r = self.ratio(mid)
                if self._within(mid, target):
                    break
                if (self.ratio(lo) - target) * (r - target) <= 0:
                    hi = mid
                else:
                    lo = mid
            if any(self._within(x, target) for x in (lo, hi, 0.5 * (lo + hi)) if x in self.cache):
                break
        # Closest ratio; among those within the tolerance the tightest bound (the best accuracy of its ratio).
        within = [x for x in self.cache if self._within(x, target)]
        if within:
            return min(within)
        return min(self.cache, key=lambda x: abs(math.log(self.cache[x] / target)))

    def describe(self, x, target):
        """The row's setting; says so when the target lies below the mode's smallest ratio (then the row is at a
        larger ratio than the target's, which can only handicap SZ3 in the comparison)."""
        floor = self.ratio(x) > target * (1.0 + TOLERANCE) and self.ratio(x) <= min(self.cache.values())
        return self.setting(x) + (" (floor: no bound reaches the target)" if floor else "")

    def _within(self, x, target):
        return abs(self.ratio(x) / target - 1.0) <= TOLERANCE
