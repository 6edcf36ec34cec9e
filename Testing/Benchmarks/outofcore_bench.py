"""Issue 22's out-of-core benchmark (pvbatch, the plugin loaded; meant for the GPU machine, CPU works too): a procedural
file larger than the budget (default 3456^3 uint8, 41 GB; ooc_procedural.py, a slab at a time, all cores), then

  1. the disk's random-read bandwidth for the buffer's block size (--disk-tool nvDiskRandomRead: the file dropped from
     the page cache, random blocks read row by row with pread from 4 threads, as the block buffer reads);
  2. Neural Compress out of core (MemoryBudget, default 8 GiB) for STEPS steps: the PSNR over wall time (its training
     log: estimates every PSNRInterval steps, exact at the end), the steps/s, the buffer's read throughput (bytes read,
     /proc/self/io rchar, less the two whole-file passes, over the training seconds) and its share of (1);
  3. the same settings in memory, host-sampled (TrainingStrategy 2), on a 2 GB grid of the same function that fits
     (default 1280^3 uint8), loaded by ParaView's NRRD reader: steps/s and the PSNR curve at the same steps; and that
     2 GB grid out of core too (a 512 MiB budget): the PSNR gap at the same steps on the same data;
  4. peak RSS (VmHWM) of the process during (2), above its resident memory before.

Each file is dropped from the page cache before it is trained from. --parts splits the work over calls (generate
with plain Python first, then large, then crop, --keep until the last); the JSON gathers them. Writes JSON to --json.
Example (the GPU machine, see README "Out-of-core files"):
  NV_PLUGIN=.../NeuralVolume.so pvbatch Testing/Benchmarks/outofcore_bench.py --folder /tmp/ooc --json ooc.json
"""
import argparse
import json
import os
import subprocess
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


def figure(data, name):
    array = data.GetFieldData().GetArray(name)
    return array.GetValue(0) if array is not None else None


def train_out_of_core(path, budget_mib, settings, file_bytes):
    """Neural Compress from the file within the budget: figures, curve, reads, peak memory."""
    from paraview.simple import Delete
    from paraview import servermanager
    reader = globals()["NeuralOutOfCoreReader"](FileName=path)
    nc = globals()["NeuralCompress"](Input=reader, MemoryBudget=budget_mib, TrainInBackground=0, **settings)
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")
    rss_before, read_before, start = status_kib("VmRSS"), bytes_read(), time.time()
    nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    result = {"wall_s": time.time() - start, "training_s": figure(out, "NeuralTrainingSeconds"),
              "steps": figure(out, "NeuralSteps"), "psnr_exact": figure(out, "NeuralPSNR"),
              "exact": figure(out, "NeuralPSNRExact"), "curve": psnr_curve(servermanager.Fetch(nc, idx=1)),
              "bytes_read": bytes_read() - read_before,
              "peak_rss_above_before_mib": (status_kib("VmHWM") - rss_before) / 1024.0,
              "rss_before_mib": rss_before / 1024.0}
    result["steps_per_s"] = result["steps"] / result["training_s"]
    # The buffer's reads: all bytes read less the two whole-file passes (value range, exact PSNR); the probe's few
    # rows are left in. Over the training seconds (the buffer's readers run while it trains).
    result["buffer_read_mb_per_s"] = (result["bytes_read"] - 2 * file_bytes) / result["training_s"] / 1e6
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


def generated(python, path, dims, type_name, item):
    """The file (generated unless already there, complete) and the seconds its generation took (0 if reused)."""
    raw = os.path.splitext(path)[0] + ".raw"
    if os.path.exists(path) and os.path.exists(raw) and os.path.getsize(raw) == dims[0] * dims[1] * dims[2] * item:
        return raw, 0.0
    return generate(python, path, dims, type_name)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--folder", default="/tmp/ooc-bench")
    parser.add_argument("--dims", type=int, nargs=3, default=[3456, 3456, 3456])
    parser.add_argument("--crop", type=int, nargs=3, default=[1280, 1280, 1280])
    parser.add_argument("--type", default="uint8")
    parser.add_argument("--budget-mib", type=float, default=8192)
    parser.add_argument("--crop-budget-mib", type=float, default=512,
                        help="the budget of the crop's out-of-core run (a quarter of a 2 GB crop: out of core too)")
    parser.add_argument("--steps", type=int, default=10000)
    parser.add_argument("--device", default="CUDA")
    parser.add_argument("--batch", type=int, default=65536)
    parser.add_argument("--disk-seconds", type=float, default=20)
    parser.add_argument("--disk-tool", default="",
                        help="nvDiskRandomRead (Testing/Benchmarks, built with the project): the disk's random-read "
                             "bandwidth at the buffer's block pattern (without it, not measured: Python's per-row "
                             "calls would measure Python, not the disk)")
    parser.add_argument("--parts", default="generate,large,crop",
                        help="any of generate (the files, plain Python), large (out of core, the disk), crop (the crop "
                             "in memory and out of core); the JSON gathers the parts run so far")
    parser.add_argument("--keep", action="store_true", help="keep the generated files")
    parser.add_argument("--python", default="python3", help="a Python with numpy for the generator")
    parser.add_argument("--json", default="outofcore_bench.json")
    args = parser.parse_args()
    parts = set(args.parts.split(","))

    if parts - {"generate"}:
        from paraview.simple import LoadPlugin
        LoadPlugin(os.environ["NV_PLUGIN"], remote=False, ns=globals())
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
    raw, generate_s = generated(args.python, large, args.dims, args.type, item)
    crop_raw, crop_generate_s = generated(args.python, crop, args.crop, args.type, item)
    result["generate_s"] = result.get("generate_s") or generate_s
    result["file_bytes"] = os.path.getsize(raw)
    settings = dict(TrainingSteps=args.steps, BatchSize=args.batch, Device=args.device, TimeBudget=0, Seed=5,
                    PSNRInterval=250, OutputMode="Network only")
    if "large" in parts:
        drop_from_page_cache(raw)
        result["ooc"] = train_out_of_core(large, args.budget_mib, settings, result["file_bytes"])
        # The block edge the buffer chose (vtkNeuralOutOfCoreInput.cxx, BlockCellsFor: 5/8 of the budget, 32 blocks
        # a batch sample): the disk's bandwidth for that block size.
        buffer_bytes = args.budget_mib * 2 ** 20 * 5 / 8
        edge = next((e for e in range(32, 2, -1) if buffer_bytes / ((e + 1) ** 3 * 4 + 28) >= 32 * args.batch), 2)
        if args.disk_tool:
            measured = json.loads(subprocess.run([args.disk_tool, raw] + [str(n) for n in args.dims] +
                                                 [str(item), str(edge), str(args.disk_seconds), "4"], check=True,
                                                 capture_output=True, text=True).stdout)
            result["disk_random_read"] = measured
            result["disk_random_read_mb_per_s"] = measured["mb_per_s"]
            result["ooc"]["share_of_disk"] = result["ooc"]["buffer_read_mb_per_s"] / measured["mb_per_s"]
    if "crop" in parts:
        drop_from_page_cache(crop_raw)
        result["crop_ooc"] = train_out_of_core(crop, args.crop_budget_mib, settings, os.path.getsize(crop_raw))
        result["memory"] = train_in_memory(crop, settings)
    if "ooc" in result and "memory" in result:
        result["ooc_step_rate_share"] = result["ooc"]["steps_per_s"] / result["memory"]["steps_per_s"]
    if "crop_ooc" in result and "memory" in result:
        result["crop_psnr_gap_db"] = result["memory"]["psnr"] - result["crop_ooc"]["psnr_exact"]
    if not args.keep:
        for path in (large, raw, crop, crop_raw):
            os.remove(path)
    with open(args.json, "w") as f:
        json.dump(result, f, indent=1)
    print(json.dumps({k: v for k, v in result.items() if not isinstance(v, dict)}, indent=1))
    for key in ("ooc", "crop_ooc", "memory"):
        if key in result:
            print(key, json.dumps({k: v for k, v in result[key].items() if k != "curve"}, indent=1))
    os._exit(0)


if __name__ == "__main__":
    main()
