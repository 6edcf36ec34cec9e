"""Issue 22's test of scale: a procedural file of 2 GiB (ooc_procedural.py: Marschner-Lobb plus band-limited noise,
float64 1024 x 512 x 512: half the samples of float32, so the streamed measurement of every voxel takes half),
generated into the build folder by a process of its own (a slab at a time) and removed afterwards, trained out of
core by Neural Compress on the CPU engine with MemoryBudget 128 MiB:

  * peak resident memory of this process while it trains (VmHWM after a reset of the peak through
    /proc/self/clear_refs, less VmRSS before) <= the budget + the model (16 bytes a parameter: the parameters, their
    gradients and Adam's two moments) + OVERHEAD_MIB (the batch and its activations, the trainer's threads and
    buffers, the network decoded a slab at a time in the streamed pass; measured below);
  * the exact PSNR streamed over every voxel of the file at N steps is within 1.5 dB of Neural Compress in memory at
    the same N steps on a grid of the same function that fits (512 x 256 x 256, the same settings);
  * the file is removed at the end (also when a check fails).

The streamed PSNR of a network against the in-memory PSNR of the same network to 1e-6 dB is engine.OutOfCore's.
Skipped (with the reason) when the build folder has less than 3 GB free. 3 to 5 minutes on 2 cores.
"""
import os
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log

LARGE = (1024, 512, 512)    # float64: 2 GiB
SMALL = (512, 256, 256)     # the same function on a grid that fits (256 MiB)
TYPE = "float64"
BUDGET_MIB = 128
OVERHEAD_MIB = 64
NEEDED_FREE = 3 * 10 ** 9
# FinestResolution fixed: both networks the same (by default it follows the grid).
SETTINGS = dict(TrainingSteps=400, BatchSize=8192, Levels=12, FeaturesPerLevel=2, Log2TableSize=16, FinestResolution=1024,
                NetworkWidth=32, HiddenLayers=2, Threads=2, PSNRInterval=100, Device="CPU", TimeBudget=0, Seed=5, TrainInBackground=0,
                OutputMode="Network only")
GENERATOR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ooc_procedural.py")

FOLDER = os.path.join(nvtest.output_dir(), "outofcore_large")
shutil.rmtree(FOLDER, ignore_errors=True)
os.makedirs(FOLDER)
free = shutil.disk_usage(FOLDER).free
if free < NEEDED_FREE:
    shutil.rmtree(FOLDER, ignore_errors=True)
    nvtest.skip("the build folder has %.2f GB free; the 2 GiB file needs %.0f GB" % (free / 1e9, NEEDED_FREE / 1e9))


def status_kib(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise RuntimeError("no %s in /proc/self/status" % field)


def figure(data, name):
    array = data.GetFieldData().GetArray(name)
    return array.GetValue(0) if array is not None else None


def generate(name, dims):
    """The file, written by a process of its own (this one's peak memory stays its own)."""
    path = os.path.join(FOLDER, name + ".nhdr")
    start = time.time()
    subprocess.run(["/usr/bin/python3", GENERATOR, path] + [str(n) for n in dims] + ["--type", TYPE], check=True,
                   capture_output=True)
    log("%s: %d x %d x %d %s, %.0f MiB, written in %.1f s" % (name, dims[0], dims[1], dims[2], TYPE,
                                                                  os.path.getsize(path[:-5] + ".raw") / 2 ** 20,
                                                                  time.time() - start))
    return path


def train_out_of_core(path):
    """Neural Compress from the file within the budget; returns the output, the seconds and the peak memory above
    the resident memory before (MiB)."""
    reader = NeuralOutOfCoreReader(FileName=path)
    nc = NeuralCompress(Input=reader, MemoryBudget=BUDGET_MIB, **SETTINGS)
    nc.UpdatePipelineInformation()
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # the peak (VmHWM) restarts from the resident memory now
    before = status_kib("VmRSS")
    start = time.time()
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    seconds = time.time() - start
    peak = status_kib("VmHWM")
    out = servermanager.Fetch(nc)
    check("ERROR" not in messages[0], "no error (%s)" % messages[0].strip()[:400])
    log("out of core: VmRSS before %.1f MiB, VmHWM while training %.1f MiB" % (before / 1024, peak / 1024))
    Delete(nc)
    Delete(reader)
    return out, seconds, (peak - before) / 1024.0


def train_in_memory(path):
    """Neural Compress of the file's samples loaded by ParaView's own NRRD reader."""
    reader = OpenDataFile(path)
    reader.UpdatePipeline()
    name = reader.PointData.keys()[0]
    nc = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", name], **SETTINGS)
    start = time.time()
    nc.UpdatePipeline()
    seconds = time.time() - start
    out = servermanager.Fetch(nc)
    Delete(nc)
    Delete(reader)
    return out, seconds


def main():
    small = generate("small", SMALL)
    memory, memory_seconds = train_in_memory(small)
    memory_psnr = figure(memory, "NeuralPSNR")
    log("in memory (%s): %.3f dB after %d steps in %.1f s" % ("x".join(map(str, SMALL)), memory_psnr,
                                                            figure(memory, "NeuralSteps"), memory_seconds))
    large = generate("large", LARGE)
    out, seconds, peak_mib = train_out_of_core(large)
    psnr, exact = figure(out, "NeuralPSNR"), figure(out, "NeuralPSNRExact")
    model_mib = 16.0 * figure(out, "NeuralModelBytes") / 2.0 / 2 ** 20  # stored as float16: parameters x 2 bytes
    bound = BUDGET_MIB + model_mib + OVERHEAD_MIB
    log("out of core (%s, MemoryBudget %d MiB): %.3f dB (exact %s) after %d steps in %.1f s (value-range scan, "
        "training, the streamed measurement); peak memory while training %.1f MiB above before, bound %.1f MiB "
        "(budget %d + model %.1f + overhead %d); gap to in memory %.3f dB"
        % ("x".join(map(str, LARGE)), BUDGET_MIB, psnr, exact, figure(out, "NeuralSteps"), seconds, peak_mib, bound,
           BUDGET_MIB, model_mib, OVERHEAD_MIB, memory_psnr - psnr))
    check(exact == 1, "the PSNR is exact (streamed over every voxel)")
    check(figure(out, "NeuralSteps") == SETTINGS["TrainingSteps"], "trained every step")
    check(peak_mib == peak_mib and peak_mib <= bound, "peak memory %.1f MiB <= %.1f MiB" % (peak_mib, bound))
    check(psnr == psnr and memory_psnr == memory_psnr and psnr >= memory_psnr - 1.5,
          "out of core within 1.5 dB of in memory (%.3f vs %.3f dB)" % (psnr, memory_psnr))


try:
    main()
finally:
    shutil.rmtree(FOLDER, ignore_errors=True)
    check(not os.path.exists(FOLDER), "the generated files are removed")
nvtest.finish()
