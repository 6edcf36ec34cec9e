"""Each MPI rank on the GPU of its local rank (issue 23), under `mpiexec -n 2` or `-n 4 pvbatch` on a machine with
GPUs (label gpu-paraview; SKIP without a usable GPU or with another rank count). Neural Compress trains one network per rank
(Device Auto) on its piece of a Wavelet; checks:
- every rank trained on CUDA (NeuralDevice) on device NeuralCudaDevice == its local rank modulo the GPUs it sees
  (every rank runs on this host: rank r's local rank is r), so on as many GPUs as ranks rank r uses device r;
- nvidia-smi shows each rank's process holding memory on a GPU of its own (with at least as many GPUs as ranks);
- the global PSNR is the same on every rank and >= 30 dB, and the composited picture of the ranks' GPU sessions is
  a volume (not the background);
- a second filter with Device CPU trains on the CPU on every rank (NeuralCudaDevice -1): CPU and GPU ranks mix.
Every rank's device, ordinal, PSNR and training seconds are printed (RANK lines) and written to gpu_ranks.json.
"""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkParallelCore import vtkMultiProcessController  # noqa: E402

WHOLE = [0, 127, 0, 127, 0, 127]
SETTINGS = dict(SelectInputScalars=["POINTS", "RTData"], Seed=7, TrainingSteps=1000, BatchSize=65536,
                PSNRInterval=0, TrainInBackground=0, OutputMode="Network only")
MIN_PSNR = 30.0
SIZE = [256, 256]
BACKGROUND = [0.32, 0.34, 0.43]
PID_SCRIPT = ("import os\nfrom vtkmodules.vtkCommonCore import vtkDoubleArray\nout = self.GetOutput()\n"
              "a = vtkDoubleArray()\na.SetName('pid')\na.InsertNextValue(os.getpid())\nout.AddColumn(a)\n")

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log
out_dir = os.path.join(nvtest.output_dir(), "GpuRanks")


def fetch_all(proxy, ranks):
    return [servermanager.Fetch(proxy, r) for r in range(ranks)]


def rank_pids(ranks):
    """The process id of every rank (a programmable source runs on each)."""
    saved = dict(globals())
    source = ProgrammableSource(OutputDataSetType="vtkTable", Script=PID_SCRIPT)
    source.UpdatePipeline()
    pids = [int(t.GetColumnByName("pid").GetValue(0)) for t in fetch_all(source, ranks)]
    Delete(source)
    for name in [k for k in globals() if k not in saved]:
        del globals()[name]
    globals().update(saved)
    return pids


def nvidia_smi(query):
    try:
        text = subprocess.run(["nvidia-smi", "--query-%s" % query, "--format=csv,noheader,nounits"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, timeout=60).stdout.decode()
    except (OSError, subprocess.SubprocessError):
        return []
    return [[field.strip() for field in line.split(",")] for line in text.splitlines() if line.strip()]


def visible_gpus():
    """GPUs this process's CUDA runtime sees: CUDA_VISIBLE_DEVICES (set by a launcher) or every GPU nvidia-smi lists."""
    visible = os.environ.get("CUDA_VISIBLE_DEVICES")
    if visible is not None:
        return len([d for d in visible.split(",") if d.strip()])
    return len(nvidia_smi("gpu=index"))


def gpus_of(pids):
    """pid -> the PCI bus ids of the GPUs where nvidia-smi shows it holding memory."""
    out = {pid: set() for pid in pids}
    for row in nvidia_smi("compute-apps=pid,gpu_bus_id"):
        if len(row) >= 2 and row[0].isdigit() and int(row[0]) in out:
            out[int(row[0])].add(row[1])
    return out


def picture(nc, path):
    pixels = nvtest.wavelet_picture(nc, path, SIZE, WHOLE, (330.0, -240.0, 450.0), BACKGROUND)
    return float(np.mean(np.abs(pixels - np.array(BACKGROUND) * 255.0).max(axis=2) > 8.0))


def main():
    controller = vtkMultiProcessController.GetGlobalController()
    ranks = controller.GetNumberOfProcesses() if controller else 1
    if ranks not in (2, 4):
        nvtest.skip("this test runs under `mpiexec -n 2` or `-n 4 pvbatch` (here %d processes)" % ranks)
    nvtest.require_display()
    os.makedirs(out_dir, exist_ok=True)
    wavelet = Wavelet(WholeExtent=WHOLE)
    nc = NeuralCompress(Input=wavelet, Device="Auto", **SETTINGS)
    nc.UpdatePropertyInformation()
    if not nc.GetPropertyValue("GPUUsable"):
        nvtest.skip("no usable GPU on rank 0")
    gpus = visible_gpus()
    with nvtest.captured_messages() as messages:
        nc.UpdatePipeline()
    check("ERROR" not in messages[0], "no error: %r" % messages[0][-400:])
    pieces = fetch_all(nc, ranks)
    pids = rank_pids(ranks)
    held = gpus_of(pids)
    report = []
    for r, piece in enumerate(pieces):
        row = dict(rank=r, pid=pids[r], device=nvtest.field_value(piece, "NeuralDevice"),
                   cuda_device=nvtest.field_value(piece, "NeuralCudaDevice"),
                   psnr=nvtest.field_value(piece, "NeuralPSNR"),
                   seconds=nvtest.field_value(piece, "NeuralTrainingSeconds"),
                   steps=nvtest.field_value(piece, "NeuralSteps"), gpus_held=sorted(held[pids[r]]))
        report.append(row)
        log("RANK %d: %s device %s, PSNR %.3f dB, %d steps in %.3f s, pid %d on GPU(s) %s"
            % (r, row["device"], row["cuda_device"], row["psnr"], row["steps"], row["seconds"], pids[r],
               row["gpus_held"]))
        check(row["device"] == "CUDA", "rank %d trained on CUDA (%s)" % (r, row["device"]))
        check(gpus > 0 and row["cuda_device"] == r % gpus, "rank %d on device %s == local rank %d mod %d GPUs"
              % (r, row["cuda_device"], r, gpus))
    if gpus >= ranks:
        own = [held[pid] for pid in pids]
        check(all(len(g) == 1 for g in own) and len({frozenset(g) for g in own}) == ranks,
              "nvidia-smi: each rank's process on a GPU of its own (%s)" % own)
    psnrs = [row["psnr"] for row in report]
    check(len(set(psnrs)) == 1 and psnrs[0] >= MIN_PSNR, "the global PSNR is the same on every rank and >= %.0f dB "
          "(%s)" % (MIN_PSNR, psnrs))
    covered = picture(nc, os.path.join(out_dir, "gpu_ranks.png"))
    check(covered > 0.1, "the composited picture shows the volume (%.0f%% of the pixels)" % (100 * covered))
    cpu = NeuralCompress(Input=wavelet, Device="CPU", **dict(SETTINGS, TrainingSteps=50, BatchSize=16384))
    cpu.UpdatePipeline()
    for r, piece in enumerate(fetch_all(cpu, ranks)):
        device, ordinal = nvtest.field_value(piece, "NeuralDevice"), nvtest.field_value(piece, "NeuralCudaDevice")
        log("RANK %d with Device CPU: %s device %s" % (r, device, ordinal))
        check(device == "CPU" and ordinal == -1, "rank %d with Device CPU trained on the CPU (%s, %s)"
              % (r, device, ordinal))
    with open(os.path.join(out_dir, "gpu_ranks.json"), "w") as f:
        json.dump(dict(gpus=gpus, ranks=report, picture_coverage=covered), f, indent=1)


main()
nvtest.finish()
