"""Training throughput of Neural Compress with one network per rank (issue 23), under `mpiexec -n R pvbatch`.

Usage: mpiexec -n R pvbatch distributed_scaling.py <plugin.so> <mode: strong|weak> [steps=300] [threads=1] [size=128]
         [device=CPU|CUDA|Auto] [batch=16384]
  strong: a Wavelet of size^3 points split over the R ranks;  weak: size^2 x (size * R) points (size^3 per rank).
Every rank trains its own piece (fixed seed; device CPU by default; CUDA: each rank on the GPU of its local rank); the
throughput of a rank is its steps x batch over its training seconds (field data NeuralTrainingSeconds), summed over
the ranks. Prints one RESULT line (JSON): ranks, mode, device, whole extent, per-rank seconds, samples/s, devices
(NeuralDevice) and CUDA device ordinals (NeuralCudaDevice), their sum, the wall time of the update, the global PSNR,
each rank's peak RSS growth over its RSS before the pipeline (MiB), and on GPUs the device memory each process holds
once trained (nvidia-smi's used memory of every compute process, MiB: the CUDA context, the piece, the network).
"""
import json
import os
import subprocess
import sys
import time

from paraview.simple import *  # noqa: F401,F403
from paraview import servermanager
from vtkmodules.vtkParallelCore import vtkMultiProcessController

plugin, mode = sys.argv[1], sys.argv[2]
steps = int(sys.argv[3]) if len(sys.argv) > 3 else 300
threads = int(sys.argv[4]) if len(sys.argv) > 4 else 1
size = int(sys.argv[5]) if len(sys.argv) > 5 else 128
device = sys.argv[6] if len(sys.argv) > 6 else "CPU"
BATCH = int(sys.argv[7]) if len(sys.argv) > 7 else 16384
LoadPlugin(plugin, remote=False, ns=globals())
controller = vtkMultiProcessController.GetGlobalController()
ranks = controller.GetNumberOfProcesses() if controller else 1
depth = size * ranks if mode == "weak" else size
whole = [0, size - 1, 0, size - 1, 0, depth - 1]
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "ParaView"))
import nvtest  # noqa: E402

before = nvtest.rank_memory(ranks)
wavelet = Wavelet(WholeExtent=whole)
nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], Device=device, Seed=7, Deterministic=1,
                    TrainingSteps=steps, BatchSize=BATCH, Levels=8, FeaturesPerLevel=2, NetworkWidth=32,
                    HiddenLayers=2, Loss="L2", Log2TableSize=14, Threads=threads, PSNRInterval=0,
                    TrainInBackground=0, OutputMode="Network only")
started = time.time()
nc.UpdatePipeline()
wall = time.time() - started
seconds, psnr, devices, ordinals = [], None, [], []
for r in range(ranks):
    data = servermanager.Fetch(nc, r) if ranks > 1 else servermanager.Fetch(nc)
    fd = data.GetFieldData()
    seconds.append(fd.GetArray("NeuralTrainingSeconds").GetValue(0))
    psnr = fd.GetArray("NeuralPSNR").GetValue(0)
    devices.append(fd.GetAbstractArray("NeuralDevice").GetValue(0))
    ordinal = fd.GetArray("NeuralCudaDevice")
    ordinals.append(ordinal.GetValue(0) if ordinal is not None else None)
after = nvtest.rank_memory(ranks)
# Each rank's peak RSS growth over its RSS before the pipeline (the piece, its network, the engine's buffers).
growth_mib = [round((a[1] - b[0]) / 2 ** 20, 1) for a, b in zip(after, before)]


def gpu_memory_mib():
    """nvidia-smi's used memory (MiB) of every compute process on the machine (only the ranks run there)."""
    try:
        text = subprocess.run(["nvidia-smi", "--query-compute-apps=pid,used_memory", "--format=csv,noheader,nounits"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, timeout=60).stdout.decode()
    except (OSError, subprocess.SubprocessError):
        return []
    rows = [line.split(",") for line in text.splitlines() if line.strip()]
    return [float(row[1]) for row in sorted(rows, key=lambda row: int(row[0]))]


gpu_mib = gpu_memory_mib() if device != "CPU" else []
rates = [steps * BATCH / s for s in seconds]
print("RESULT " + json.dumps(dict(ranks=ranks, mode=mode, device=device, threads=threads, whole=whole, steps=steps,
                                  batch=BATCH, devices=devices, cuda_devices=ordinals, seconds=seconds, samples_per_s=rates, total_samples_per_s=sum(rates),
                                  wall_s=wall, psnr=psnr, peak_rss_growth_mib=growth_mib,
                                  gpu_memory_mib=gpu_mib)))
