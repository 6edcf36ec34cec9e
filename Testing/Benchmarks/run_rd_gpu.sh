#!/usr/bin/env bash
# The GPU rows of the rate-distortion table (issue 25), on the device machine. Carried: .devcarry/bin (nvBench of the
# CUDA build and its libNeuralEngine.so), .devcarry/ref (the PyTorch reference: quality_torch.py, bench_torch.py),
# .devcarry/data/{stent,walnut,headsq} (as ../shared/data). The 512^3 procedural volumes are generated here by
# tradeoff_volumes.py (seed 1; 512 MiB each, too large to carry). Results go to $OUT (or ./rd-out).
# Usage: run_rd_gpu.sh SECTION...
#   prep      (on the CPU machine, before the device call; BUILD_CUDA=build-cuda by default) fills .devcarry/bin with
#             nvBench and libNeuralEngine.so of the CUDA build, .devcarry/ref with the reference scripts of
#             ../shared/reference, .devcarry/data/{stent,walnut,headsq} from ../shared/data, .devcarry/COMMIT: about
#             28 MB to carry
#   volumes   generate .devcarry/proc/{mlnoise,rmmixing}_512_float.nhdr (about 20 s)
#   net512    the engine on both 512^3 volumes: tables 2^15..2^19 (fp16 ratios 72, 38, 20, 11, 5.9:1; 8-bit about
#             2.4x), 4000 and 16000 steps (default annealed schedule, one run per step count), fp16 and 8-bit rows
#             from the same runs, seed 1; PSNR over every voxel by nvBench (no dump at this size)
#   torch512  the PyTorch reference at 2^17 on both 512^3 volumes, seeds 1-3, 4000 steps; the engine at 2^17,
#             4000 steps, seeds 2 and 3 (seed 1 is in net512): equal steps over three seeds
#   seeds     the data folder's missing PyTorch seeds (2026-11-25 had 2 at 2^14, 1 at 2^18): 2^14 seed 3 on headsq,
#             stent, walnut; 2^18 seeds 2 and 3 on stent and walnut; 4000 steps
# Then, on the CPU machine: Testing/Benchmarks/rd_table.sh OUT_DIR... (the folders the device calls' $OUT came back
# in; SZ3 bisection at the new ratios, then the table, its CSV, plots and the README's part).
set -u
B=.devcarry/bin
D=.devcarry/data
P=.devcarry/proc
O=${OUT:-rd-out}
mkdir -p "$O"
if [ "${1:-}" = prep ]; then
  C=${BUILD_CUDA:-build-cuda}
  mkdir -p $B .devcarry/ref
  cp "$C/Testing/Benchmarks/nvBench" "$C/lib/paraview-plugins/NeuralVolume/libNeuralEngine.so" $B/
  cp ../shared/reference/quality_torch.py ../shared/reference/bench_torch.py .devcarry/ref/
  for v in stent walnut headsq; do mkdir -p $D/$v && cp ../shared/data/$v/*.nhdr ../shared/data/$v/*.raw $D/$v/; done
  git rev-parse --short HEAD > .devcarry/COMMIT  # the rows' commit (the device's copy has no git history)
  du -sh .devcarry/bin .devcarry/ref $D
  exit 0
fi
for f in $B/*.xz; do [ -e "$f" ] && xz -d -f "$f"; done
chmod +x $B/nvBench 2>/dev/null
export LD_LIBRARY_PATH=$PWD/$B${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
T="python3 Testing/Benchmarks/tradeoff.py"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$O/gpu.txt" 2>&1
for s in "$@"; do
  start=$(date +%s)
  case $s in
    volumes)
      python3 Testing/Benchmarks/tradeoff_volumes.py $P --size 512 --seed 1 ;;
    net512)
      $T neural --device cuda --nvbench $B/nvBench --out "$O/net512" --volumes $P/*_512_float.nhdr \
        --tables 15,16,17,18,19 --steps 4000,16000 --seeds 1 2>&1 | tail -3 ;;
    torch512)
      $T torch --torch .devcarry/ref --out "$O/torch512" --volumes $P/*_512_float.nhdr --torch-tables 17 \
        --torch-steps 4000 --torch-seeds 1,2,3 2>&1 | tail -3
      $T neural --device cuda --nvbench $B/nvBench --out "$O/torch512" --volumes $P/*_512_float.nhdr --tables 17 \
        --steps 4000 --seeds 2,3 --storage fp16 2>&1 | tail -3 ;;
    seeds)
      $T torch --torch .devcarry/ref --out "$O/seeds" --volumes $D/headsq/*.nhdr $D/stent/*.nhdr $D/walnut/*.nhdr \
        --torch-tables 14 --torch-steps 4000 --torch-seeds 3 2>&1 | tail -2
      $T torch --torch .devcarry/ref --out "$O/seeds" --volumes $D/stent/*.nhdr $D/walnut/*.nhdr \
        --torch-tables 18 --torch-steps 4000 --torch-seeds 2,3 2>&1 | tail -2 ;;
    *) echo "unknown section $s" ;;
  esac
  echo "section $s: $(( $(date +%s) - start )) s" | tee -a "$O/sections.txt"
done
