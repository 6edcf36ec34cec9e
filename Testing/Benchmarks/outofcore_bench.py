"""Issue 22's out-of-core benchmark (pvbatch, the plugin loaded; meant for the GPU machine, CPU works too): a procedural
file larger than the budget (default 2176^3 float32, 41 GB; ooc_procedural.py, a slab at a time, all cores), then

  1. the disk's random-read bandwidth for the buffer's block shape (--disk-tool nvDiskRandomRead: random blocks read
     by the engine's file reader, as the block buffer reads them, from as many threads as the buffer's readers and
     from --disk-threads (the best of the two is the disk's figure); --disk-mode direct (default): O_DIRECT, whole 4 KiB pages,
     as fio --direct=1, the disk itself whatever the machine's memory; cold: pread after dropping the file from the
     page cache);
  2. Neural Compress out of core (MemoryBudget, default 8 GiB) for STEPS steps: the PSNR over wall time (its training
     log: estimates every PSNRInterval steps, exact at the end), the steps/s, the buffer's read throughput (the
     filter's NeuralBufferBytesRead less NeuralBufferFirstFillBytes: the bytes of the blocks read while training, over
     the training seconds) and its share of (1); --bypass: the buffer's readers bypass the page cache
     (BypassPageCache: O_DIRECT, the same block shape and pattern as (1)), so that the share means the disk's
     share on a machine whose memory holds the file; NeuralBufferSwapsMissed says whether the reads held it up; the
     seconds of each phase (the filter's NeuralValueRangeSeconds, NeuralFirstFillSeconds, NeuralTrainingSeconds,
     NeuralExactPassSeconds), each phase's start, tenths and end logged on stderr as it goes (the filter's vtkLogF
     lines: a run stopped by a timeout still tells where it was);
  3. the same settings in memory, host-sampled (TrainingStrategy 2), on a 2 GB grid of the same function that fits
     (default 800^3 float32), loaded by ParaView's NRRD reader: steps/s and the PSNR curve at the same steps; and that
     2 GB grid out of core too (a 512 MiB budget): the PSNR gap at the same steps on the same data;
  4. peak RSS (VmHWM) of the process during (2), above its resident memory before.

Each file is dropped from the page cache before it is trained from. --parts splits the work over calls (generate
with plain Python first, then large, then crop, --keep until the last); the JSON gathers them. Only `generate` writes
files: `large` and `crop` stop with a message when the file on disk is missing or its header differs from --dims,
--crop or --type (they never regenerate 41 GB because an argument was not repeated). Writes JSON to --json.
Example (the GPU machine, see README "Out-of-core files"):
  NV_PLUGIN=.../NeuralVolume.so pvbatch Testing/Benchmarks/outofcore_bench.py --folder /tmp/ooc --json ooc.json
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def status_kib(name):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(name + ":"))


def bytes_read():
    with open("/proc/self/io") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("rchar:"))


def psnr_curve(log_table):
    """[(elapsed s, step, PSNR)] from Neural Compress's training log (output port 1) where a PSNR was taken."""
    columns = {log_table.GetColumnName(c): log_table.GetColumn(c) for c in range(log_table.GetNumberOfColumns())}
    curve = []
    for row in range(log_table.GetNumberOfRows()):
        psnr = columns["PSNR"].GetValue(row)
        if psnr == psnr:
            curve.append((round(columns["ElapsedSeconds"].GetValue(row), 3), int(columns["Step"].GetValue(row)), psnr))
    return curve


def generate(python, path, dims, type_name):
    """The generator in a process of its own (forking pvbatch for its workers is not safe)."""
    start = time.time()
    subprocess.run([python, os.path.join(HERE, "..", "ParaView", "ooc_procedural.py"), path] + [str(n) for n in dims] +
                   ["--type", type_name, "--workers", str(os.cpu_count() or 1)], check=True)
    return os.path.splitext(path)[0] + ".raw", time.time() - start


def progress(text):
    """A line on stderr at once: a run killed by a timeout still tells where it was."""
    sys.stderr.write("[outofcore_bench %s] %s\n" % (time.strftime("%H:%M:%S"), text))
    sys.stderr.flush()


def header_of(path):
    """(sizes, NRRD type) of an .nhdr, or None when it is not there."""
    if not os.path.exists(path):
        return None
    fields = {}
    with open(path) as f:
        for line in f:
            if ":" in line:
                key, value = line.split(":", 1)
                fields[key.strip()] = value.strip()
    return [int(n) for n in fields.get("sizes", "").split()], fields.get("type")


def nrrd_type(type_name):
    return {"uint8": "uchar", "int16": "short", "float32": "float", "float64": "double"}[type_name]


def figure(data, name):
    array = data.GetFieldData().GetArray(name)
    return array.GetValue(0) if array is not None else None


def train_out_of_core(path, budget_mib, settings, file_bytes):
    # (file_bytes: the rchar figure below subtracts the two whole-file passes)
    """Neural Compress from the file within the budget: figures, curve, reads, peak memory."""
    from paraview.simple import Delete
    from paraview import servermanager
    reader = globals()["NeuralOutOfCoreReader"](FileName=path)
    nc = globals()["NeuralCompress"](Input=reader, MemoryBudget=budget_mib, TrainInBackground=0, **settings)
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")
    rss_before, read_before, start = status_kib("VmRSS"), bytes_read(), time.time()
    progress("%s: Neural Compress out of core started (value-range pass, first fill, training, exact pass)" % path)
    nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    result = {"wall_s": time.time() - start, "training_s": figure(out, "NeuralTrainingSeconds"),
              "value_range_s": figure(out, "NeuralValueRangeSeconds"),
              "first_fill_s": figure(out, "NeuralFirstFillSeconds"),
              "exact_pass_s": figure(out, "NeuralExactPassSeconds"),
              "steps": figure(out, "NeuralSteps"), "psnr_exact": figure(out, "NeuralPSNR"),
              "exact": figure(out, "NeuralPSNRExact"), "curve": psnr_curve(servermanager.Fetch(nc, idx=1)),
              "bytes_read": bytes_read() - read_before,
              "buffer_bytes_read": figure(out, "NeuralBufferBytesRead"),
              "buffer_bytes_transferred": figure(out, "NeuralBufferBytesTransferred"),
              "buffer_first_fill_bytes": figure(out, "NeuralBufferFirstFillBytes"),
              "buffer_swaps_missed": figure(out, "NeuralBufferSwapsMissed"),
              "bypass_page_cache": settings.get("BypassPageCache", 0),
              "peak_rss_above_before_mib": (status_kib("VmHWM") - rss_before) / 1024.0,
              "rss_before_mib": rss_before / 1024.0}
    result["steps_per_s"] = result["steps"] / result["training_s"]
    progress("%s: done in %.1f s (value range %s s, first fill %s s, training %s s, exact pass %s s)" % tuple(
        [path, result["wall_s"]] + ["%.1f" % result[k] if result[k] is not None else "?" for k in (
            "value_range_s", "first_fill_s", "training_s", "exact_pass_s")]))
    # The buffer's reads while it trained: the bytes of the blocks read after the first fill, over the training
    # seconds (the readers run while it trains); rchar less the two whole-file passes as before, for comparison.
    if result["buffer_bytes_read"] is not None and result["buffer_first_fill_bytes"] is not None:
        result["buffer_read_mb_per_s"] = (result["buffer_bytes_read"] - result["buffer_first_fill_bytes"]) / \
            result["training_s"] / 1e6
    result["rchar_read_mb_per_s"] = (result["bytes_read"] - 2 * file_bytes) / result["training_s"] / 1e6
    Delete(nc)
    Delete(reader)
    return result


def train_in_memory(path, settings):
    """The same settings on a grid loaded by ParaView's NRRD reader, host-sampled."""
    from paraview.simple import Delete, OpenDataFile
    from paraview import servermanager
    image = OpenDataFile(path)
    image.UpdatePipeline()
    memory = globals()["NeuralCompress"](Input=image, SelectInputScalars=["POINTS", image.PointData.keys()[0]],
                                         TrainInBackground=0, TrainingStrategy=2, **settings)
    memory.UpdatePipeline()
    out = servermanager.Fetch(memory)
    result = {"training_s": figure(out, "NeuralTrainingSeconds"), "steps": figure(out, "NeuralSteps"),
              "psnr": figure(out, "NeuralPSNR"), "curve": psnr_curve(servermanager.Fetch(memory, idx=1))}
    result["steps_per_s"] = result["steps"] / result["training_s"]
    Delete(memory)
    Delete(image)
    return result


def drop_from_page_cache(raw):
    """Written pages flushed, then the file dropped from the page cache: training reads the disk, not memory."""
    os.sync()
    fd = os.open(raw, os.O_RDONLY)
    os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
    os.close(fd)


def matches(path, dims, type_name, item):
    """Whether the file on disk is the one the arguments describe: its header's sizes and type, its raw size."""
    raw = os.path.splitext(path)[0] + ".raw"
    return (header_of(path) == (list(dims), nrrd_type(type_name)) and os.path.exists(raw) and
            os.path.getsize(raw) == dims[0] * dims[1] * dims[2] * item)


def generated(python, path, dims, type_name, item):
    """The file (generated unless already there, complete) and the seconds its generation took (0 if reused)."""
    raw = os.path.splitext(path)[0] + ".raw"
    if matches(path, dims, type_name, item):
        return raw, 0.0
    if header_of(path) is not None:
        progress("%s holds %s, not %s %s: generating it again" % (path, header_of(path), dims, type_name))
    progress("generating %s: %s %s" % (path, dims, type_name))
    return generate(python, path, dims, type_name)


def existing(path, dims, type_name, item, option):
    """The raw file of a part that trains from it; stops when it is missing or differs from the arguments."""
    if not matches(path, dims, type_name, item):
        found = header_of(path)
        sys.exit("outofcore_bench: %s %s, the arguments ask for %s %s (%s, --type): run --parts generate with the "
                 "same arguments first, or repeat the arguments it was generated with" % (
                     path, "is missing" if found is None else "holds %s %s" % found, dims, nrrd_type(type_name),
                     option))
    return os.path.splitext(path)[0] + ".raw"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--folder", default="/tmp/ooc-bench")
    parser.add_argument("--dims", type=int, nargs=3, default=[2176, 2176, 2176])
    parser.add_argument("--crop", type=int, nargs=3, default=[800, 800, 800])
    parser.add_argument("--type", default="float32", choices=["uint8", "int16", "float32", "float64"])
    parser.add_argument("--budget-mib", type=float, default=8192)
    parser.add_argument("--crop-budget-mib", type=float, default=512,
                        help="the budget of the crop's out-of-core run (a quarter of a 2 GB crop: out of core too)")
    parser.add_argument("--steps", type=int, default=10000)
    parser.add_argument("--device", default="CUDA")
    parser.add_argument("--batch", type=int, default=65536)
    parser.add_argument("--disk-seconds", type=float, default=20)
    parser.add_argument("--disk-threads", type=int, default=32,
                        help="the disk is also measured at this many threads (a deeper queue than the buffer's readers)")
    parser.add_argument("--disk-mode", default="direct", choices=["direct", "cold"],
                        help="direct: O_DIRECT page reads (the disk itself); cold: pread after dropping the cache")
    parser.add_argument("--bypass", action="store_true",
                        help="the large file's block buffer bypasses the page cache (BypassPageCache=1, O_DIRECT)")
    parser.add_argument("--disk-tool", default="",
                        help="nvDiskRandomRead (Testing/Benchmarks, built with the project): the disk's random-read "
                             "bandwidth at the buffer's block pattern (without it, not measured: Python's per-row "
                             "calls would measure Python, not the disk)")
    parser.add_argument("--parts", default="generate,large,crop",
                        help="any of generate (the files, plain Python), generate-crop (the crop's file only), large "
                             "(out of core, the disk), crop (the crop in memory and out of core); the JSON gathers the "
                             "parts run so far")
    parser.add_argument("--set", default="", metavar="NAME=VALUE,...",
                        help="more Neural Compress properties for every run, e.g. Levels=4,Log2TableSize=14 (a small "
                             "network: a CPU run's exact pass is mostly decoding)")
    parser.add_argument("--keep", action="store_true", help="keep the generated files")
    parser.add_argument("--python", default="python3", help="a Python with numpy for the generator")
    parser.add_argument("--json", default="outofcore_bench.json")
    args = parser.parse_args()
    parts = set(args.parts.split(","))

    os.makedirs(args.folder, exist_ok=True)
    result = {}
    if os.path.exists(args.json):
        with open(args.json) as f:
            result = json.load(f)
    result.update({"dims": args.dims, "crop": args.crop, "type": args.type, "budget_mib": args.budget_mib,
                   "crop_budget_mib": args.crop_budget_mib, "steps": args.steps, "device": args.device,
                   "batch": args.batch})
    item = {"uint8": 1, "int16": 2, "float32": 4, "float64": 8}[args.type]
    large, crop = os.path.join(args.folder, "large.nhdr"), os.path.join(args.folder, "crop.nhdr")
    if "generate" in parts:
        raw, generate_s = generated(args.python, large, args.dims, args.type, item)
        crop_raw, _ = generated(args.python, crop, args.crop, args.type, item)
        result["generate_s"] = generate_s or result.get("generate_s")
        progress("files ready: %s, %s" % (raw, crop_raw))
    if "generate-crop" in parts:
        crop_raw, _ = generated(args.python, crop, args.crop, args.type, item)
        progress("file ready: %s" % crop_raw)
    if "large" in parts:
        raw = existing(large, args.dims, args.type, item, "--dims")
    if "crop" in parts:
        crop_raw = existing(crop, args.crop, args.type, item, "--crop")
    if "generate" in parts or "large" in parts:
        result["file_bytes"] = os.path.getsize(raw)
    if parts - {"generate", "generate-crop"}:
        from paraview.simple import LoadPlugin
        from vtkmodules.vtkCommonCore import vtkLogger
        LoadPlugin(os.environ["NV_PLUGIN"], remote=False, ns=globals())
        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_INFO)  # the filter's phase lines as they happen
    settings = dict(TrainingSteps=args.steps, BatchSize=args.batch, Device=args.device, TimeBudget=0, Seed=5,
                    PSNRInterval=250, OutputMode="Network only")
    for item_text in filter(None, args.set.split(",")):
        name, value = item_text.split("=", 1)
        settings[name] = float(value) if "." in value else int(value) if value.lstrip("-").isdigit() else value
    result["set"] = args.set
    if "large" in parts:
        drop_from_page_cache(raw)
        large_settings = dict(settings, BypassPageCache=1) if args.bypass else settings
        result["ooc"] = train_out_of_core(large, args.budget_mib, large_settings, result["file_bytes"])
        # The block shape the buffer chose (vtkNeuralOutOfCoreInput.cxx, BlockShapeFor: 5/8 of the budget, the
        # longest brick of up to 128 x 2 x 2 cells beside a GPU trainer, 64 x 2 x 2 else, of which it holds one per
        # sample of the batch, else 2^3-cell cubes): the disk's bandwidth for it.
        buffer_bytes = args.budget_mib * 2 ** 20 * 5 / 8
        cells = 2
        longest = (128,) if args.device == "CUDA" else ()
        cells_x = next((x for x in longest + (64, 32, 16, 8, 4) if buffer_bytes / ((x + 1) * 9 * 4 + 28) >= args.batch), 2)
        if args.disk_tool:
            # The buffer's reader threads (vtkNeuralOutOfCoreInput.cxx, OutOfCoreReaderThreads: 32 with the bypass;
            # beside a GPU trainer the cores less two, 4 to 16), and a deeper queue: the disk's bandwidth is the best of
            # the two, the share is taken against it.
            readers = 32 if args.bypass else max(4, min(16, (os.cpu_count() or 1) - 2)) if args.device == "CUDA" else 4
            runs = []
            for threads in sorted({readers, max(readers, args.disk_threads)}):
                progress("the disk's random-read bandwidth (%s, %d x %d x %d-cell blocks, %s, %d threads, %g s)" % (
                    args.disk_tool, cells_x, cells, cells, args.disk_mode, threads, args.disk_seconds))
                runs.append(json.loads(subprocess.run(
                    [args.disk_tool, raw] + [str(n) for n in args.dims] +
                    [str(item), str(cells), str(args.disk_seconds), str(threads), str(cells_x), args.disk_mode],
                    check=True, capture_output=True, text=True).stdout))
            measured = max(runs, key=lambda run: run["mb_per_s"])
            result["disk_random_read_runs"] = runs
            result["disk_random_read"] = measured
            result["disk_random_read_mb_per_s"] = measured["mb_per_s"]
            result["buffer_reader_threads"] = readers
            if result["ooc"].get("buffer_read_mb_per_s") is not None:
                result["ooc"]["share_of_disk"] = result["ooc"]["buffer_read_mb_per_s"] / measured["mb_per_s"]
    if "crop" in parts:
        drop_from_page_cache(crop_raw)
        result["crop_ooc"] = train_out_of_core(crop, args.crop_budget_mib, settings, os.path.getsize(crop_raw))
        progress("%s: in memory, host-sampled" % crop)
        result["memory"] = train_in_memory(crop, settings)
        progress("%s: in memory done, %.1f steps/s" % (crop, result["memory"]["steps_per_s"]))
    if "ooc" in result and "memory" in result:
        result["ooc_step_rate_share"] = result["ooc"]["steps_per_s"] / result["memory"]["steps_per_s"]
    if "crop_ooc" in result and "memory" in result:
        result["crop_psnr_gap_db"] = result["memory"]["psnr"] - result["crop_ooc"]["psnr_exact"]
    if not args.keep:
        for path in (large, crop):
            for name in (path, os.path.splitext(path)[0] + ".raw"):
                if os.path.exists(name):
                    os.remove(name)
    with open(args.json, "w") as f:
        json.dump(result, f, indent=1)
    print(json.dumps({k: v for k, v in result.items() if not isinstance(v, dict)}, indent=1))
    for key in ("ooc", "crop_ooc", "memory"):
        if key in result:
            print(key, json.dumps({k: v for k, v in result[key].items() if k != "curve"}, indent=1))
    os._exit(0)


if __name__ == "__main__":
    main()
