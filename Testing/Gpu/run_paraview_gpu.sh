#!/usr/bin/env bash
# The gpu-paraview tests on the device machine, inside Debian's ParaView unpacked there (no ParaView can be installed):
#   here:  bash ../shared/tools/pv-runtime/pack.sh .devcarry/pvrt 60        (ParaView's runtime, xz parts)
#          tar -cJf .devcarry/plugin.tar.xz -C build-cuda/lib/paraview-plugins NeuralVolume   (a CUDA build)
#          cp "$(readlink -f /usr/bin/pvserver)" .devcarry/bin/pvserver
#          carry .devcarry/pvrt a few parts per call (64 MiB a call; they stay while the machine is held), then
#   there: Testing/Gpu/run_paraview_gpu.sh [TEST...]   (default: TestGpuParaView)
# Each pvbatch test runs with the plugin (paraview_gpu_env.sh); logs, JSON and pictures go to
# .devcarry/gpu-paraview-out (the caller packs them for $OUT: at most 8 files come back).
set -u
source "$(dirname "$0")/paraview_gpu_env.sh"
status=0
for t in ${@:-TestGpuParaView}; do
  echo "== $t"
  timeout 1500 "$NV_PVBATCH" --force-offscreen-rendering "$here/Testing/ParaView/$t.py" > "$out/$t.log" 2>&1
  rc=$?
  echo "rc=$rc"; tail -25 "$out/$t.log"
  [ $rc -eq 0 ] || status=1
done
exit $status
