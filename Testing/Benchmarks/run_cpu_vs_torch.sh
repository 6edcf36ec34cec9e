#!/usr/bin/env bash
# The CPU engine's training step (paper configuration: 2^19 table, finest 4096, batch 65536) side by side with the
# PyTorch reference (../shared/reference/torch_cpu_step.py, carried in .devcarry/ref) at 1, 2 and all threads, on
# the machine it runs on (the device machine has g++, cmake and PyTorch). Builds the engine there (-march=native).
# 1 and 2 threads are pinned to cores 0 / 0,1. The reference sets 2 threads itself: it runs unmodified, with
# torch.set_num_threads redirected to the count asked for. Results go to $OUT (or ./cpu-vs-torch-out).
set -u
O=${OUT:-cpu-vs-torch-out}
mkdir -p "$O"
ALL=$(nproc)
B=/tmp/nv-cpu-build
lscpu | grep -E "Model name|^CPU\(s\)" | tee "$O/cpu.txt"
cmake -S . -B $B -G Ninja -DNV_ENGINE_ONLY=ON -DNV_ENABLE_CUDA=OFF -DCMAKE_BUILD_TYPE=Release > "$O/build.log" 2>&1 &&
  cmake --build $B -j"$ALL" --target nvBench >> "$O/build.log" 2>&1 || { tail -20 "$O/build.log"; exit 1; }
pin() { case $1 in 1) echo "taskset -c 0";; 2) echo "taskset -c 0,1";; *) echo "";; esac; }
for T in 1 2 "$ALL"; do
  for r in 1 2 3; do
    echo "engine threads=$T $($(pin $T) $B/Testing/Benchmarks/nvBench step cpu 65536 19 4096 5 --threads=$T | grep RESULT)"
  done
  for r in 1 2; do
    echo "torch threads=$T $(cd .devcarry/ref && $(pin $T) python3 -c "
import sys, torch
n = $T
f = torch.set_num_threads
torch.set_num_threads = lambda _ignored: f(n)
sys.argv = ['torch_cpu_step.py', 'bench_torch.py', '65536']
exec(compile(open('torch_cpu_step.py').read(), 'torch_cpu_step.py', 'exec'))
" 2>&1 | tail -1)"
  done
done | tee "$O/cpu_vs_torch.log"
