#!/usr/bin/env bash
# The frame as ParaView shows it on the device machine (issue 24), after run_paraview_gpu.sh's setup (see there):
# Testing/Benchmarks/gpu_paraview_frames.py on the Wavelet (256^3) and, when carried, the stent, then the state
# restore on the GPU against stock Volume (state_restore.py --device CUDA --stock). JSON and logs: .devcarry/gpu-paraview-out.
set -u
source "$(dirname "$0")/paraview_gpu_env.sh"
bench=$here/Testing/Benchmarks
timeout 150 "$NV_PVBATCH" --force-offscreen-rendering "$bench/gpu_paraview_frames.py" "$NV_PLUGIN" \
  "$out/frames_wavelet256.json" > "$out/frames_wavelet256.log" 2>&1; echo "frames wavelet rc=$?"
stent=$NV_DATA_DIR/stent/stent_128x128x256_int16.nhdr
if [ -f "$stent" ]; then
  timeout 110 "$NV_PVBATCH" --force-offscreen-rendering "$bench/gpu_paraview_frames.py" "$NV_PLUGIN" \
    "$out/frames_stent.json" --data "$stent" > "$out/frames_stent.log" 2>&1; echo "frames stent rc=$?"
fi
timeout 150 "$NV_PVBATCH" --force-offscreen-rendering "$bench/state_restore.py" "$NV_PLUGIN" "$out/state" \
  --source wavelet --n 256 --steps 300 --repeat 2 --device CUDA --stock > "$out/state_restore_gpu.log" 2>&1
echo "state restore rc=$?"; grep RESULT "$out/state_restore_gpu.log" | tail -3
