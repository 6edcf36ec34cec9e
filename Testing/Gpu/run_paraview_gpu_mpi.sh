#!/usr/bin/env bash
# Issue 23's GPU checks on the device machine (2 GPUs), inside Debian's ParaView unpacked there: each MPI rank on the
# GPU of its local rank (Testing/ParaView/TestNeuralCompressGpuRanks.py under mpiexec -n 2 pvbatch: RANK lines give
# each rank's device), then the strong and weak scaling of training on the GPUs at 1 and 2 ranks
# (Testing/Benchmarks/run_distributed_bench.sh, JSON lines in distributed_gpu.jsonl). Needs what run_paraview_gpu.sh
# needs plus Open MPI carried as .devcarry/mpi-extras.tar.xz (Testing/Gpu/pack_mpi_extras.sh).
#   there: Testing/Gpu/run_paraview_gpu_mpi.sh [steps=2000] [size=256] [batch=262144]
set -u
source "$(dirname "$0")/paraview_gpu_env.sh"
if [ -z "${NV_MPIEXEC:-}" ]; then
  echo "no Open MPI here: carry .devcarry/mpi-extras.tar.xz (Testing/Gpu/pack_mpi_extras.sh)"
  exit 1
fi
status=0
echo "== TestNeuralCompressGpuRanks (mpiexec -n 2 pvbatch)"
nvidia-smi -L
timeout 600 "$NV_MPIEXEC" --allow-run-as-root --oversubscribe -n 2 "$NV_PVBATCH" --force-offscreen-rendering \
  "$here/Testing/ParaView/TestNeuralCompressGpuRanks.py" > "$out/TestNeuralCompressGpuRanks.log" 2>&1
rc=$?
echo "rc=$rc"; grep -E "RANK|FAIL|SKIP|checks passed|check\(s\) failed" "$out/TestNeuralCompressGpuRanks.log" | tail -20
[ $rc -eq 0 ] || status=1
echo "== strong and weak scaling on the GPUs (1 and 2 ranks)"
NV_MPIEXEC=$NV_MPIEXEC NV_PVBATCH=$NV_PVBATCH NV_PLUGIN=$NV_PLUGIN bash "$here/Testing/Benchmarks/run_distributed_bench.sh" \
  none "$out/distributed_gpu.jsonl" "1 2" "${1:-2000}" 1 "${2:-256}" CUDA "${3:-262144}" || status=1
exit $status
