#!/usr/bin/env bash
# The gpu-paraview tests on the device machine, inside Debian's ParaView unpacked there (no ParaView can be installed):
#   here:  bash ../shared/tools/pv-runtime/pack.sh .devcarry/pvrt 60        (ParaView's runtime, xz parts)
#          tar -cJf .devcarry/plugin.tar.xz -C build-cuda/lib/paraview-plugins NeuralVolume   (a CUDA build)
#          carry .devcarry/pvrt a few parts per call (64 MiB a call; they stay while the machine is held), then
#   there: Testing/Gpu/run_paraview_gpu.sh [TEST...]   (default: TestGpuParaView)
# Unpacks once into .devcarry/pvrt-root, starts Xvfb with NVIDIA's GLX, runs each pvbatch test with the plugin;
# logs and pictures go to $OUT.
set -u
here=$(pwd)
root=$here/.devcarry/pvrt-root
out=$here/.devcarry/gpu-paraview-out   # pictures stay there while the machine is held; logs also go to $OUT
back=${OUT:-$out}
mkdir -p "$out"
if [ ! -f "$root/env.sh" ]; then
  bash "$here/.devcarry/unpack.sh" "$here/.devcarry/pvrt" "$root" > "$out/unpack.log" 2>&1 || { cat "$out/unpack.log"; exit 1; }
fi
if [ ! -d "$here/.devcarry/plugin/NeuralVolume" ]; then
  mkdir -p "$here/.devcarry/plugin" && tar -xJf "$here/.devcarry/plugin.tar.xz" -C "$here/.devcarry/plugin"
fi
# shellcheck disable=SC1091
source "$root/env.sh"
plugin_dir=$here/.devcarry/plugin/NeuralVolume
export LD_LIBRARY_PATH=$plugin_dir:$LD_LIBRARY_PATH
export __GLX_VENDOR_LIBRARY_NAME=nvidia PYTHONUNBUFFERED=1
export NV_PLUGIN=$plugin_dir/NeuralVolume.so NV_TEST_OUTPUT=$out NV_PVBATCH=$root/usr/bin/pvbatch
export NV_DATA_DIR=$here/.devcarry/data NV_BASELINE_DIR=$here/Testing/ParaView/Baseline
pgrep -f "Xvfb :57" > /dev/null || { Xvfb :57 -screen 0 1920x1200x24 -nolisten tcp -xkbdir "$NV_XKB_DIR" > "$out/xvfb.log" 2>&1 & sleep 2; }
export DISPLAY=:57
nvidia-smi --query-gpu=name,driver_version --format=csv > "$out/gpu.txt"
status=0
for t in ${@:-TestGpuParaView}; do
  echo "== $t"
  timeout 1500 "$NV_PVBATCH" --force-offscreen-rendering "$here/Testing/ParaView/$t.py" > "$out/$t.log" 2>&1
  rc=$?
  echo "rc=$rc"; tail -25 "$out/$t.log"
  [ $rc -eq 0 ] || status=1
done
[ "$back" = "$out" ] || cp "$out"/*.log "$out"/*.json "$out"/gpu.txt "$back"/ 2>/dev/null
exit $status
