#!/usr/bin/env bash
# CPU engine benchmark: training step time at the paper configuration and across table/batch sizes, the stent
# accuracy curve, and wall-clock-budget runs used to choose the filter's defaults.
# usage: Testing/Benchmarks/run_cpu_bench.sh BUILD_DIR [DATA_DIR] > results.txt
set -euo pipefail
build=${1:?build dir}
data=${2:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}
bench="$build/Testing/Benchmarks/nvBench"
echo "# date $(date -u +%F) host $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p') commit $(git -C "$(dirname "$0")" rev-parse --short HEAD)"
# Paper configuration: 16x4 levels, 2^19 table, base 16, finest 4096, 64x4 MLP, batch 65536.
"$bench" step cpu 65536 19 4096 7
for t in 14 16 18; do "$bench" step cpu 65536 "$t" 512 5; done
for b in 16384 262144; do "$bench" step cpu "$b" 19 4096 5; done
stent="$data/stent/stent_128x128x256_int16.nhdr"
if [ -f "$stent" ]; then
  "$bench" curve cpu "$stent" 14 250,500,1000,2000 65536 1
  # Defaults: what a one-minute budget buys at several table sizes and batch sizes.
  for b in 16384 65536; do
    for t in 14 16; do "$bench" budget cpu "$stent" "$t" 60 "$b"; done
  done
fi
