#!/bin/sh
# Strong and weak scaling of training throughput with one network per rank (issue 23) at 1 and 2 ranks (and 4 where
# the machine has the cores: pass "1 2 4"). Usage: run_distributed_bench.sh <build dir> <out.jsonl> [ranks="1 2"]
# [steps=300] [threads per rank=1] [size=128] [device=CPU] [batch=16384] [modes="strong weak"]
# GPUs (each rank on the GPU of its local rank): e.g. run_distributed_bench.sh build out.jsonl "1 2" 2000 1 256 CUDA
# 262144. NV_PLUGIN (a plugin .so) and NV_PVBATCH, NV_MPIEXEC override the plugin found in the build dir, pvbatch and
# mpiexec on PATH.
set -e
build=$1; out=$2; ranks=${3:-"1 2"}; steps=${4:-300}; threads=${5:-1}; size=${6:-128}; device=${7:-CPU}
batch=${8:-16384}; modes=${9:-"strong weak"}
plugin=${NV_PLUGIN:-$(find "$build" -name NeuralVolume.so | head -1)}
here=$(cd "$(dirname "$0")" && pwd)
: > "$out"
for mode in $modes; do
  for n in $ranks; do
    OMPI_MCA_mpi_yield_when_idle=1 timeout 900 "${NV_MPIEXEC:-mpiexec}" --allow-run-as-root --oversubscribe -n "$n" \
      "${NV_PVBATCH:-pvbatch}" "$here/distributed_scaling.py" "$plugin" "$mode" "$steps" "$threads" "$size" \
      "$device" "$batch" 2>/dev/null |
      sed -n 's/^RESULT //p' >> "$out"
  done
done
cat "$out"
