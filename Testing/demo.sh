#!/usr/bin/env bash
# Main job: build if needed, compress the built-in default volume, render it, print the figures, write an image.
# usage: Testing/demo.sh [OUTPUT.png]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${NV_BUILD_DIR:-$root/build}
mkdir -p "$build"
echo "demo: installing missing packages and building (log: $build/setup.log)"
"$root/Testing/setup.sh" > "$build/setup.log" 2>&1 || { tail -n 40 "$build/setup.log"; exit 1; }
plugin=$(find "$build/lib" -name NeuralVolume.so | head -n 1)
[ -n "$plugin" ] || { echo "demo: NeuralVolume.so not found under $build/lib" >&2; exit 1; }
out=${1:-$PWD/neural_volume.png}
if [ -n "${DISPLAY:-}" ]; then
  pvbatch "$root/Testing/demo.py" "$plugin" "$out"
else
  xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvbatch "$root/Testing/demo.py" "$plugin" "$out"
fi
