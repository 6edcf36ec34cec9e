#!/usr/bin/env bash
# Main job: build if needed, compress a 256^3 Mandelbulb (computed on the spot, no data set needed) with Neural
# Compress, render it with ParaView's Volume and with the Neural Volume, print the training time, PSNR and ratio, and
# write one picture: original | Neural Volume | error, with the PSNR over the training time. About 3 minutes on 2 cores.
# usage: Testing/demo.sh [OUTPUT.png] [demo.py options: --budget SECONDS, --size N, --steps N]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${NV_BUILD_DIR:-$root/build}
mkdir -p "$build"
echo "demo: installing missing packages and building (log: $build/setup.log)"
"$root/Testing/setup.sh" > "$build/setup.log" 2>&1 || { tail -n 40 "$build/setup.log"; exit 1; }
plugin=$(find "$build/lib" -name NeuralVolume.so | head -n 1)
[ -n "$plugin" ] || { echo "demo: NeuralVolume.so not found under $build/lib" >&2; exit 1; }
out=$PWD/neural_volume.png
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then
  out=$1
  shift
fi
if [ -n "${DISPLAY:-}" ]; then
  pvbatch "$root/Testing/demo.py" "$plugin" "$out" "$@"
else
  xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvbatch "$root/Testing/demo.py" "$plugin" "$out" "$@"
fi
