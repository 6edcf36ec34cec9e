#!/usr/bin/env bash
# Run time against error on the device machine (issue 12). Binaries in .devcarry/bin (nvBench, optionally .xz),
# volumes in .devcarry/data/<name>/*.nhdr (as ../shared/data; a .raw.xz is unpacked), the PyTorch reference scripts in
# .devcarry/ref, zfpy/pysz unpacked wheels in .devcarry/py. Usage: run_tradeoff_gpu.sh SECTION...
#   schedule  learning-rate schedules, L1 and L2, PSNR every 50 steps (collapses)
#   sweep     tradeoff.py neural sweep on the GPU (all volumes, 2^12..2^20, 250..8000 steps)
#   cpu       tradeoff.py neural sweep of the CPU engine (all volumes, 2^14 and 2^18, 250 and 500 steps, 12 threads)
#   compress  tradeoff.py ZFP and SZ3 sweep (when zfpy and pysz import)
#   torch     the paper's method in PyTorch, 4000 steps (tradeoff.py torch)
#   pair      the engine (GPU) and the PyTorch reference side by side, 2^14 (all) and 2^18 (stent, walnut)
#   importance error-guided sampling on and off, 3 seeds, 2^19 (binary nvBenchImp)
#   plateau   the loss-driven decay against the default schedule (collapses; every volume at 2^14/2^18)
#   spread    six seeds at 2^16 on a 256^3 volume and on stent, 4000 steps
#   seeds     the engine and the PyTorch reference side by side over five seeds (torch_seeded.py), the small volumes
#             at 2^14, 4000 steps; the engine also with the annealed schedules (cos, hold 0.5)
#             (summary: Testing/Benchmarks/summarize_seeds.py seeds_engine.log seeds_torch.log)
#   seeds2    the same for the larger volumes: stent, walnut and headsq at 2^14, stent and walnut at 2^18, three seeds
#             (step decay and cosine; the reference with torch_seeded.py)
#   hold      the cosine held at the full rate for the first 500 steps (the default), half or three quarters of the
#             run (--hold) against the step decay and the plain cosine, every volume and the smooth field, L1 and L2 at 2^16, 4000 steps
#   anneal    annealed learning-rate schedules (--schedule=exp|cos, to 1/100 or 1/30 of the rate at the last step)
#             against the step decay, every volume and the smooth 48^3 field, L1 and L2, 4000 steps, PSNR every 50
#             (summary: Testing/Benchmarks/summarize_schedule.py anneal.log)
# Results go to $OUT (or ./tradeoff-out).
set -u
B=.devcarry/bin
D=.devcarry/data
O=${OUT:-tradeoff-out}
mkdir -p "$O"
for f in $B/*.xz; do [ -e "$f" ] && xz -d -f "$f" && chmod +x "${f%.xz}"; done
for f in $D/*/*.raw.xz; do [ -e "$f" ] && xz -d -f -T0 "$f"; done
export PYTHONPATH=$PWD/.devcarry/py${PYTHONPATH:+:$PYTHONPATH}
VOLS=$(ls $D/{nucleon,neghip,bucky,ironprot,walnut,stent,headsq}/*.nhdr 2>/dev/null)
T="python3 Testing/Benchmarks/tradeoff.py"
# nvBench options of the schedules compared by the seeds sections (cos: the cosine from the first step; hold500: the
# default annealed schedule, full rate for 500 steps first; hold50: the cosine over the second half of 4000 steps)
variant_options() {
  case $1 in
    step) echo "--schedule=step" ;; cos) echo "--schedule=cos --hold=0" ;;
    hold50) echo "--schedule=cos --hold=2000" ;; hold500) echo "--schedule=cos --hold=500" ;;
  esac
}
# Schedule comparisons: for every volume of VOLUMES, loss:table of CFGS and variant ("name --nvBench-options"), one
# nvBench tradeoff run with PSNR at MARKS, after a line "VARIANT name loss L log2T T volume" (summarize_schedule.py
# reads them). ONLY_VARIANT=name runs that variant only. Usage: compare_schedules MARKS "VOLUMES" "CFGS" VARIANT...
compare_schedules() {
  local marks=$1 vols=$2 cfgs=$3 v cfg variant name
  shift 3
  for v in $vols; do for cfg in $cfgs; do for variant in "$@"; do
    name=${variant%% *}
    [ -n "${ONLY_VARIANT:-}" ] && [ "$name" != "$ONLY_VARIANT" ] && continue
    echo "VARIANT $name loss ${cfg%:*} log2T ${cfg#*:} $(basename $v)"
    $B/nvBench tradeoff cuda $v ${cfg#*:} $marks --loss=${cfg%:*} ${variant#"$name"}
  done; done; done
}
for s in "$@"; do
  case $s in
    schedule)
      nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$O/gpu.txt"
      compare_schedules "$(seq -s, 50 50 4000)" "$D/synth/smooth48_float.nhdr $D/neghip/*.nhdr $D/headsq/*.nhdr $D/walnut/*.nhdr $D/stent/*.nhdr" "l2:16 l2:19 l1:19" \
        "base" "warm200 --warmup=200" "eps1e-10 --eps=1e-10" \
        "fast --warmup=200 --decay-interval=500 --decay-factor=0.7" "lr3e-3 --warmup=200 --lr=3e-3" \
        > "$O/schedule.log" 2>&1 ;;
    schedule2)
      # Adam's second-moment decay and epsilon against the periodic collapses the schedule section showed.
      marks=$(seq -s, 50 50 3000)
      for run in "$D/neghip/*.nhdr l1 19" "$D/neghip/*.nhdr l2 16" "$D/headsq/*.nhdr l2 16" "$D/headsq/*.nhdr l1 19" \
                 "$D/synth/smooth48_float.nhdr l2 16" "$D/synth/smooth48_float.nhdr l1 19" "$D/stent/*.nhdr l1 16"; do
        set -- $run
        for variant in "base" "b2_0.999 --beta2=0.999" "eps1e-8 --eps=1e-8" "eps1e-6 --eps=1e-6" \
                       "b2_0.999_fast --beta2=0.999 --decay-interval=500 --decay-factor=0.7" \
                       "eps1e-8_fast --eps=1e-8 --decay-interval=500 --decay-factor=0.7"; do
          name=${variant%% *}; opts=${variant#$name}
          echo "VARIANT $name loss $2 log2T $3 $(basename $1)"
          $B/nvBench tradeoff cuda $1 $3 $marks --loss=$2 $opts
        done
      done > "$O/schedule2.log" 2>&1 ;;
    plateau)
      # The loss-driven decay (OptimizerConfig::plateauWindow) against the default schedule, PSNR every 100 steps,
      # then every volume at 2^14 and 2^18.
      compare_schedules "$(seq -s, 100 100 4000)" "$D/synth/smooth48_float.nhdr $D/neghip/*.nhdr $D/headsq/*.nhdr $D/walnut/*.nhdr $D/stent/*.nhdr" "l2:16 l2:19 l1:19" \
        "base" "plateau100 --plateau=100" "plateau50 --plateau=50" > "$O/plateau.log" 2>&1
      for v in $VOLS; do for t in 14 18; do for p in 0 100; do
        echo "VARIANT plateau$p loss l1 log2T $t $(basename $v)"
        $B/nvBench tradeoff cuda $v $t 1000,2000,4000 --plateau=$p
      done; done; done > "$O/plateau_volumes.log" 2>&1 ;;
    sweep)
      $T neural --device cuda --nvbench $B/nvBench --out "$O/sweep" --volumes $VOLS 2>&1 | tail -5 ;;
    cpu)
      $T neural --device cpu --nvbench $B/nvBench --out "$O/cpu" --volumes $VOLS --cpu-tables 14,18 \
        --cpu-steps 250,500 --threads 12 2>&1 | tail -5 ;;
    compress)
      $T compressors --out "$O/compress" --volumes $VOLS 2>&1 | tail -5 ;;
    torch)
      $T torch --torch .devcarry/ref --out "$O/torch" --volumes $VOLS --torch-tables 14 --torch-steps 4000 2>&1 | tail -3
      $T torch --torch .devcarry/ref --out "$O/torch" --volumes $D/stent/*.nhdr $D/walnut/*.nhdr --torch-tables 18 \
        --torch-steps 4000 2>&1 | tail -3 ;;
    pair)
      # The engine and the PyTorch reference side by side in one run: same volumes, tables and step marks.
      $T neural --device cuda --nvbench $B/nvBench --out "$O/pair" --volumes $VOLS --tables 14 \
        --steps 250,500,1000,2000,4000 2>&1 | tail -2
      $T neural --device cuda --nvbench $B/nvBench --out "$O/pair" --volumes $D/stent/*.nhdr $D/walnut/*.nhdr \
        --tables 18 --steps 250,500,1000,2000,4000 2>&1 | tail -2
      timeout 420 $T torch --torch .devcarry/ref --out "$O/pair" --volumes $VOLS --torch-tables 14 --torch-steps 4000 2>&1 | tail -3
      timeout 100 $T torch --torch .devcarry/ref --out "$O/pair" --volumes $D/stent/*.nhdr $D/walnut/*.nhdr --torch-tables 18 \
        --torch-steps 4000 2>&1 | tail -3 ;;
    importance)
      # Error-guided sampling (TrainConfig::importanceGrid, 16^3 cells) against uniform sampling, three seeds, 2^19.
      for v in $VOLS; do for seed in 1 2 3; do for imp in 0 16; do
        $B/nvBenchImp tradeoff cuda $v 19 1000,2000,4000 --seed=$seed --importance=$imp | sed "s/^RESULT/imp=$imp RESULT/"
      done; done; done > "$O/importance.log" 2>&1 ;;
    anneal)
      nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$O/gpu.txt"
      compare_schedules "$(seq -s, 50 50 4000)" "$D/synth/smooth48_float.nhdr $VOLS" "l1:16 l2:16 l1:19" \
        "base" "exp100 --schedule=exp --final=0.01 --hold=0" "cos100 --schedule=cos --final=0.01 --hold=0" \
        "cos30 --schedule=cos --final=0.0333 --hold=0" > "$O/anneal.log" 2>&1
      python3 Testing/Benchmarks/summarize_schedule.py "$O/anneal.log" > "$O/anneal.md" ;;
    seeds)
      # 2026-11-25 first run: SEED_VARIANTS="step cos hold50" (cos: --hold=0; hold50: --hold=2000); then "hold500"
      SEED_VARIANTS=${SEED_VARIANTS:-"step cos hold50 hold500"}
      small="$D/nucleon/*.nhdr $D/bucky/*.nhdr $D/ironprot/*.nhdr $D/neghip/*.nhdr"
      for seed in 1 2 3 4 5; do for v in $small; do
        for variant in $SEED_VARIANTS; do
          opts=$(variant_options $variant)
          $B/nvBench tradeoff cuda $v 14 250,500,1000,2000,4000 --seed=$seed $opts | sed "s/^RESULT/VARIANT $variant RESULT/"
        done
      done; done > "$O/seeds_engine.log" 2>&1
      [ -n "${SKIP_TORCH:-}" ] && continue
      for seed in 1 2 3 4 5; do
        timeout 150 python3 Testing/Benchmarks/torch_seeded.py $seed .devcarry/ref/quality_torch.py \
          .devcarry/ref/bench_torch.py 4000 14 $small | sed "s/^RESULT/SEED $seed RESULT/"
      done > "$O/seeds_torch.log" 2>&1 ;;
    seeds2)
      for seed in 1 2 3; do for run in "$D/stent/*.nhdr 14" "$D/walnut/*.nhdr 14" "$D/headsq/*.nhdr 14" \
                                       "$D/stent/*.nhdr 18" "$D/walnut/*.nhdr 18"; do set -- $run
        for variant in step cos hold500; do
          $B/nvBench tradeoff cuda $1 $2 1000,2000,4000 --seed=$seed $(variant_options $variant) | sed "s/^RESULT/VARIANT $variant RESULT/"
        done
      done; done > "$O/seeds2_engine.log" 2>&1
      for seed in 1 2 3; do
        timeout 120 python3 Testing/Benchmarks/torch_seeded.py $seed .devcarry/ref/quality_torch.py \
          .devcarry/ref/bench_torch.py 4000 14 $D/stent/*.nhdr $D/walnut/*.nhdr $D/headsq/*.nhdr | sed "s/^RESULT/SEED $seed RESULT/"
        timeout 90 python3 Testing/Benchmarks/torch_seeded.py $seed .devcarry/ref/quality_torch.py \
          .devcarry/ref/bench_torch.py 4000 18 $D/stent/*.nhdr $D/walnut/*.nhdr | sed "s/^RESULT/SEED $seed RESULT/"
      done > "$O/seeds2_torch.log" 2>&1 ;;
    hold)
      compare_schedules "$(seq -s, 50 50 4000)" "$D/synth/smooth48_float.nhdr $VOLS" "l1:16 l2:16" \
        "base" "cos100 --schedule=cos --hold=0" "hold50 --schedule=cos --hold=2000" \
        "hold75 --schedule=cos --hold=3000" "hold500 --schedule=cos --hold=500" > "$O/hold.log" 2>&1
      python3 Testing/Benchmarks/summarize_schedule.py "$O/hold.log" > "$O/hold.md" ;;
    spread)
      for v in $D/stent256/*.nhdr $D/stent/*.nhdr; do for seed in 1 2 3 4 5 6; do
        $B/nvBench tradeoff cuda $v 16 1000,4000 --seed=$seed; done; done 2>&1 | tee "$O/spread.log" ;;
  esac
done
