#!/usr/bin/env bash
# Issue 23's GPU checks on the device machine (2 or 4 GPUs), inside Debian's ParaView unpacked there: each MPI rank on
# the GPU of its local rank (Testing/ParaView/TestNeuralCompressGpuRanks.py under mpiexec -n 2, and -n 4 with 4 GPUs:
# RANK lines give each rank's device), shadows and path tracing across pieces on the GPUs
# (TestNeuralVolumeShadowsMPI.py --device CUDA), then the strong and weak scaling of training on the GPUs at 1, 2 (and 4) ranks
# (Testing/Benchmarks/run_distributed_bench.sh, JSON lines in distributed_gpu.jsonl), and with a memory size the
# per-rank memory of a large field split over the most ranks against one rank (distributed_gpu_memory.jsonl). Needs
# what run_paraview_gpu.sh needs plus Open MPI carried as .devcarry/mpi-extras.tar.xz (Testing/Gpu/pack_mpi_extras.sh).
#   there: Testing/Gpu/run_paraview_gpu_mpi.sh [steps=2000] [size=256] [batch=262144] [memory size=0: none]
set -u
source "$(dirname "$0")/paraview_gpu_env.sh"
if [ -z "${NV_MPIEXEC:-}" ]; then
  echo "no Open MPI here: carry .devcarry/mpi-extras.tar.xz (Testing/Gpu/pack_mpi_extras.sh)"
  exit 1
fi
steps=${1:-2000}; size=${2:-256}; batch=${3:-262144}; memory_size=${4:-0}
gpus=$(nvidia-smi -L | wc -l)
ranks="1 2"; most=2
if [ "$gpus" -ge 4 ]; then ranks="1 2 4"; most=4; fi
status=0
nvidia-smi -L
# A display per rank (ParaView's --displays): 4 pvbatch ranks opening windows on one Xvfb at once had 2 of them
# refused ("bad X server connection"), every time.
for d in 58 59 60; do
  pgrep -f "Xvfb :$d" > /dev/null || { Xvfb ":$d" -screen 0 1280x1024x24 -nolisten tcp -xkbdir "$NV_XKB_DIR" \
    > /dev/null 2>&1 & }
done
sleep 2
for n in $(echo "$ranks" | tr ' ' '\n' | grep -v '^1$'); do
  echo "== TestNeuralCompressGpuRanks (mpiexec -n $n pvbatch)"
  displays=$(seq -s, -f ':%g' 57 $((56 + n)))
  timeout 600 "$NV_MPIEXEC" --allow-run-as-root --oversubscribe -n "$n" "$NV_PVBATCH" --displays "$displays" \
    --force-offscreen-rendering \
    "$here/Testing/ParaView/TestNeuralCompressGpuRanks.py" > "$out/TestNeuralCompressGpuRanks$n.log" 2>&1
  rc=$?
  echo "rc=$rc"; grep -E "RANK|FAIL|SKIP|checks passed|check\(s\) failed" "$out/TestNeuralCompressGpuRanks$n.log" | tail -20
  [ $rc -eq 0 ] || status=1
done
echo "== TestNeuralVolumeShadowsMPI --device CUDA (mpiexec -n 2 pvbatch)"
# Its serial reference first, in a pvbatch of its own (one started by an MPI rank cannot initialise this unpacked
# Open MPI as a singleton), then the ranks with --serial-done.
mkdir -p "$out/ShadowsMPICUDA2"
timeout 300 "$NV_PVBATCH" --force-offscreen-rendering "$here/Testing/ParaView/TestNeuralVolumeShadowsMPI.py" \
  --serial-reference "$out/ShadowsMPICUDA2" --device CUDA > "$out/TestNeuralVolumeShadowsMPI2GpuSerial.log" 2>&1
# One display for both ranks: on the one-GPU machine a second Xvfb made ParaView find no remote rendering ("require
# remote rendering which, however, is not available") and the ranks' first render never returned.
timeout 600 "$NV_MPIEXEC" --allow-run-as-root --oversubscribe -n 2 "$NV_PVBATCH" \
  --force-offscreen-rendering "$here/Testing/ParaView/TestNeuralVolumeShadowsMPI.py" --device CUDA --serial-done \
  > "$out/TestNeuralVolumeShadowsMPI2Gpu.log" 2>&1
rc=$?
echo "rc=$rc"; grep -E "FAIL|SKIP|dB|ratio|checks passed|check\(s\) failed" "$out/TestNeuralVolumeShadowsMPI2Gpu.log" | tail -20
[ $rc -eq 0 ] || status=1
echo "== strong and weak scaling on the GPUs (ranks $ranks)"
NV_MPIEXEC=$NV_MPIEXEC NV_PVBATCH=$NV_PVBATCH NV_PLUGIN=$NV_PLUGIN bash "$here/Testing/Benchmarks/run_distributed_bench.sh" \
  none "$out/distributed_gpu.jsonl" "$ranks" "$steps" 1 "$size" CUDA "$batch" || status=1
if [ "$memory_size" -gt 0 ]; then
  echo "== memory: ${memory_size}^3 on 1 and $most ranks (strong)"
  NV_MPIEXEC=$NV_MPIEXEC NV_PVBATCH=$NV_PVBATCH NV_PLUGIN=$NV_PLUGIN bash \
    "$here/Testing/Benchmarks/run_distributed_bench.sh" none "$out/distributed_gpu_memory.jsonl" "1 $most" 500 1 \
    "$memory_size" CUDA "$batch" strong || status=1
fi
exit $status
