#!/usr/bin/env bash
# CPU renderer frame times: every path x shading mode at 320x240 on stent (1 spp, K = 8, skipping on), one model
# trained once (300 steps, cached in the build dir), plus skipping off for ray marching.
# usage: Testing/Benchmarks/run_cpu_render_bench.sh BUILD_DIR [DATA_DIR] > results.txt
set -euo pipefail
build=${1:?build dir}
data=${2:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}
bench="$build/Testing/Benchmarks/nvBench"
vol="$data/stent/stent_128x128x256_int16.nhdr"
model="$build/stent_render_bench.nvnet"
echo "# date $(date -u +%F) host $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p') commit $(git -C "$(dirname "$0")" rev-parse --short HEAD)"
echo "# load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
for path in decode streaming inshader; do
  for mode in rm rmgrad rmshadow pt ptnee; do
    "$bench" render "$path" "$mode" 320 240 "$vol" model="$model" frames=3
  done
  "$bench" render "$path" rm 320 240 "$vol" model="$model" frames=3 skip=0
done
echo "# load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
