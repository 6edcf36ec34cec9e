#!/bin/sh
# Path-tracing convergence raw and denoised on the CPU engine (issue 24): PSNR against 4096 paths per pixel of an
# independent seed, blob scene and stent CT, PT and PT+NEE, and the denoiser's time at 256^2 and 512^2.
# Writes results/pt_convergence_<date>.txt (the tables) and the PPM pictures into results/pt_convergence_ppm/.
#   Testing/Benchmarks/run_pt_convergence.sh [build folder]
set -e
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-build}
out="$here/results/pt_convergence_ppm"
mkdir -p "$out"
nice -n 5 "$build/Testing/Benchmarks/nvBenchPtConvergence" --size 64 --reference 4096 \
  --stent "${NV_DATA_DIR:-/work/shared/data}/stent/stent_128x128x256_int16.nhdr" --ppm "$out" \
  | tee "$here/results/pt_convergence_$(date +%Y-%m-%d).txt"
