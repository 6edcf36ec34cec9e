#!/usr/bin/env bash
# Issue 27's re-measure of the hot paths that moved (the training kernels split into named steps, the ray state's
# fields renamed), on the device machine, interleaved on one warm GPU: the step time and the render FPS of the
# binaries before the change (.devcarry/bin-base: nvBench, nvBenchRender) and after (.devcarry/bin), three rounds
# each. Logs to $OUT (or ./gpu-bench-out): remeasure_step.log, remeasure_render.log.
set -u
O=${OUT:-gpu-bench-out}
mkdir -p "$O"
for d in .devcarry/bin-base .devcarry/bin; do
  for f in $d/*.xz; do [ -e "$f" ] && xz -d -f "$f" && chmod +x "${f%.xz}"; done
done
export LD_LIBRARY_PATH=$PWD/.devcarry/bin${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}  # the new binaries link libNeuralEngine.so
STENT=.devcarry/data/stent/stent_128x128x256_int16.nhdr
for round in 1 2 3; do
  for which in base new; do
    B=.devcarry/bin; [ $which = base ] && B=.devcarry/bin-base
    for t in 14 19; do $B/nvBench step cuda 65536 $t 4096 200 | sed "s/^/$which round $round /"; done
    $B/nvBench --two-pass=1 step cuda 65536 19 4096 200 | sed "s/^/$which round $round two-pass /"
    $B/nvBench --wmma step cuda 65536 19 4096 200 | sed "s/^/$which round $round wmma /"
  done
done 2>&1 | tee "$O/remeasure_step.log"
for round in 1 2; do
  for which in base new; do
    B=.devcarry/bin; [ $which = base ] && B=.devcarry/bin-base
    $B/nvBenchRender cuda $STENT 14 2250 1280 720 decode,stream,inshader rm,pt,nee 20 | sed "s/^/$which round $round /"
  done
done 2>&1 | tee "$O/remeasure_render.log"
