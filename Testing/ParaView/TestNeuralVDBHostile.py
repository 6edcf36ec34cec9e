"""Hostile OpenVDB files never crash ParaView: truncated (25/50/75%), bit-flipped and zero-length copies of a small
.vdb written by the plugin's writer (from a Wavelet; also of smoke.vdb when NV_DATA_DIR has it) are each opened by the
OpenVDB reader in a pvbatch of their own under an address-space limit (ulimit -v, 4 GiB: pvbatch needs ~1.2 GiB) and
a time limit. Each must exit normally (no signal) within 10 s with a peak RSS under 1 GiB and print exactly one error,
which names the file and the problem. Flips in fields the header check always sees (magic, version, flags, string
lengths and counts, grid positions; several seeds) must be refused; flips elsewhere in the grid's head may also be
read without an error. The valid file still opens with the written values (numpy). Registered for builds with OpenVDB.

Run as `pvbatch TestNeuralVDBHostile.py --child FILE` it is one such child: it opens FILE and reports."""
import os
import random
import resource
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

ADDRESS_LIMIT_KB = 4 * 1024 * 1024  # ulimit -v of each child
TIME_LIMIT_S = 10.0                 # seconds of each child (killed at 3x that)
RSS_LIMIT_KB = 1024 * 1024          # peak resident memory of each child


def child(path):
    """One reader on `path`: prints its seconds and output size; errors go to the output window (stderr)."""
    import paraview.simple as simple
    from paraview import servermanager
    nvtest.load_plugin({}, scripted=False)  # the proxies join paraview.simple too
    t0 = time.time()
    reader = simple.OpenVDBReader(FileName=[path])
    reader.UpdatePipeline()
    image = servermanager.Fetch(reader)
    sys.stderr.write("NVCHILD seconds=%.3f points=%d\n" % (time.time() - t0, image.GetNumberOfPoints()))
    if image.GetNumberOfPoints() and len(sys.argv) > 3:  # the valid file: its values for the parent
        import numpy as np
        from vtkmodules.util.numpy_support import vtk_to_numpy
        np.save(sys.argv[3], vtk_to_numpy(image.GetPointData().GetScalars()))
    nvtest._exit(0)


if len(sys.argv) > 2 and sys.argv[1] == "--child":
    child(sys.argv[2])

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log
if "OpenVDBReader" not in globals():
    nvtest.skip("the plugin has no OpenVDB reader")
pvbatch = os.environ.get("NV_PVBATCH", "")
if not os.path.exists(pvbatch):
    nvtest.skip("NV_PVBATCH does not name pvbatch: %r" % pvbatch)
out_dir = os.path.join(nvtest.output_dir(), "vdb_hostile")
os.makedirs(out_dir, exist_ok=True)


def run_child(path, values_out=None):
    """Opens `path` in a pvbatch of its own (ulimit -v); returns (status, seconds, peak RSS KB, output)."""
    log_path = path + ".log"
    args = [pvbatch, os.path.abspath(__file__), "--child", path] + ([values_out] if values_out else [])

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_LIMIT_KB * 1024, ADDRESS_LIMIT_KB * 1024))
    t0 = time.time()
    with open(log_path, "wb") as out:
        p = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, preexec_fn=limit)
        while True:
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.time() - t0 > 3 * TIME_LIMIT_S:
                p.kill()
                pid, status, usage = os.wait4(p.pid, 0)
                break
            time.sleep(0.05)
    p.returncode = 0  # reaped by wait4
    seconds = time.time() - t0
    with open(log_path, "rb") as f:
        text = f.read().decode("utf-8", "replace")
    return status, seconds, usage.ru_maxrss, text


def layout(data):
    """Byte positions of the fields of a .vdb (format 222-224, one pass): what the flips below aim at."""
    fields = {"magic": (0, 8), "version": (8, 12), "offsets flag": (20, 21)}
    pos = 57 if struct.unpack_from("<I", data, 8)[0] >= 218 else 37
    fields["file metadata count"] = (pos + 2, pos + 4)
    count = struct.unpack_from("<I", data, pos)[0]
    pos += 4

    def string(name):
        nonlocal pos
        n = struct.unpack_from("<I", data, pos)[0]
        if name:
            fields[name] = (pos + 2, pos + 4)  # its high bytes: a length far past the file
        pos += 4 + n
    for i in range(count):
        string("file metadata name length" if i == 0 else None)
        string(None)
        pos += 4 + struct.unpack_from("<I", data, pos)[0]
    pos += 4
    string("grid name length")
    string("grid type length")
    string(None)
    fields["grid position"] = (pos, pos + 8)
    fields["end position (high bytes)"] = (pos + 20, pos + 24)
    grid_pos = struct.unpack_from("<q", data, pos)[0]
    fields["grid head"] = (grid_pos, grid_pos + 200)
    return fields


def copies(label, data):
    """(name, bytes, must_refuse) of the hostile copies of `data`."""
    made = [("%s_trunc%d" % (label, p), data[:len(data) * p // 100], True) for p in (25, 50, 75)]
    made.append(("%s_zero" % label, b"", True))
    fields = layout(data)
    for seed in range(1, 4):  # every always-refused field, a random bit of a random byte of it per seed
        rng = random.Random(seed)
        for name, (a, b) in sorted(fields.items()):
            if name == "grid head":
                continue
            f = bytearray(data)
            at = rng.randrange(a, b)
            f[at] ^= 1 << rng.randrange(8)
            made.append(("%s_flip_%s_%d" % (label, name.replace(" ", "_").strip("()"), seed), bytes(f), True))
    for seed in range(1, 5):  # the grid's head (metadata, transform type): an error or a clean read
        rng = random.Random(100 + seed)
        f = bytearray(data)
        for _ in range(3):
            f[rng.randrange(*fields["grid head"])] ^= 1 << rng.randrange(8)
        made.append(("%s_flip_head_%d" % (label, seed), bytes(f), False))
    return made


figures = []


def open_hostile(name, data, must_refuse):
    path = os.path.join(out_dir, name + ".vdb")
    with open(path, "wb") as f:
        f.write(data)
    status, seconds, rss, text = run_child(path)
    errors = [line for line in text.splitlines() if "ERR|" in line or "ERROR" in line]
    ours = [line for line in errors if "OpenVDB reader: '%s'" % path in line]
    message = ours[0].split("OpenVDB reader: ", 1)[1] if ours else ""
    figures.append((name, seconds, rss, message))
    log("%-40s %5.2f s %6.0f MB  %s" % (name, seconds, rss / 1024.0, message[:300]))
    check(os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, "%s: a normal exit (status %s; %s)"
          % (name, status, text.strip()[-300:]))
    check(seconds <= TIME_LIMIT_S, "%s: within %g s (%.2f s)" % (name, TIME_LIMIT_S, seconds))
    check(rss <= RSS_LIMIT_KB, "%s: peak RSS %d KB <= %d KB" % (name, rss, RSS_LIMIT_KB))
    check(len(errors) <= 1 and len(ours) == len(errors), "%s: at most one error, the reader's (%s)"
          % (name, errors[:3]))
    check(len(message) < 1000, "%s: a short message (%d characters)" % (name, len(message)))
    if must_refuse:
        check(len(ours) == 1 and "NVCHILD" in text and "points=0" in text,
              "%s: one clear error naming the file, an empty output (%s)" % (name, text.strip()[-300:]))
    else:
        check(("points=0" in text) == (len(ours) == 1), "%s: an error exactly when the output is empty" % name)
    if "trunc" in name:
        check("the file is truncated" in message and "claims bytes up to" in message,
              "%s: the message says the file is truncated (%s)" % (name, message))
    if "zero" in name:
        check("the file is empty (0 bytes)" in message, "%s: the message says the file is empty" % name)


# 1. A small .vdb of our own: the Wavelet's RTData (17^3, no voxel at the background 0: all active).
wavelet = Wavelet(WholeExtent=[-8, 8] * 3)
expected = vtk_to_numpy(servermanager.Fetch(wavelet).GetPointData().GetArray("RTData")).astype(np.float32)
valid = os.path.join(out_dir, "wavelet.vdb")
SaveData(valid, proxy=wavelet, ArrayName="RTData")
with open(valid, "rb") as f:
    data = f.read()
log("wavelet.vdb: %d bytes, fields %s" % (len(data), layout(data)))
values_path = os.path.join(out_dir, "wavelet_values.npy")
status, seconds, rss, text = run_child(valid, values_path)
log("wavelet.vdb (valid) %.2f s %.0f MB" % (seconds, rss / 1024.0))
check(os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0 and "ERR|" not in text,
      "the valid file opens without an error (%s)" % text.strip()[-300:])
got = np.load(values_path) if os.path.exists(values_path) else np.zeros(0)
check(got.shape == expected.shape and np.array_equal(got, expected),
      "the valid file gives the written values (%s vs %s)" % (got.shape, expected.shape))
figures.append(("wavelet (valid)", seconds, rss, ""))
for name, hostile, must in copies("wavelet", data):
    open_hostile(name, hostile, must)

# 2. smoke.vdb of the data folder (skipped when absent): its truncated copies and a few flips.
smoke = os.path.join(os.environ.get("NV_DATA_DIR", ""), "openvdb_smoke1", "smoke.vdb")
if os.path.exists(smoke):
    with open(smoke, "rb") as f:
        data = f.read()
    for name, hostile, must in copies("smoke", data)[:8]:  # truncations, zero, the first seed's flips
        open_hostile(name, hostile, must)
    status, seconds, rss, text = run_child(smoke)
    log("smoke.vdb (valid) %.2f s %.0f MB" % (seconds, rss / 1024.0))
    check(os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0 and "points=0" not in text and "ERR|" not in text,
          "smoke.vdb opens without an error")
else:
    log("smoke.vdb not found under NV_DATA_DIR: its part is skipped")

log("worst: %.2f s, %.0f MB peak RSS over %d children" % (max(f[1] for f in figures),
    max(f[2] for f in figures) / 1024.0, len(figures)))
nvtest.finish()
