#!/usr/bin/env bash
# The frame as ParaView shows it on the device machine (issue 24), after run_paraview_gpu.sh's setup (see there):
# Testing/Benchmarks/gpu_paraview_frames.py on the Wavelet (256^3) and, when carried, the stent, then the state
# restore on the GPU against stock Volume (state_restore.py --device CUDA --stock), and, with the GUI's extras carried
# (pack_gui_extras.sh), the GUI's frame rate while the view turns (gui_frames.sh). JSON and logs: .devcarry/gpu-paraview-out.
# usage: run_paraview_gpu_bench.sh [PART...] with PART in frames, frames512, state, gui, guifull (default: frames state gui)
# guifull: the GUI with the layout full screen (F11), its window sized to a 1280x720 then a 1920x1080 view
set -u
source "$(dirname "$0")/paraview_gpu_env.sh"
bench=$here/Testing/Benchmarks
frames() { # NAME LIMIT_S ARGS...
  local name=$1 limit=$2; shift 2
  timeout "$limit" "$NV_PVBATCH" --force-offscreen-rendering "$bench/gpu_paraview_frames.py" "$NV_PLUGIN" \
    "$out/frames_$name.json" "$@" > "$out/frames_$name.log" 2>&1
  echo "frames $name rc=$?"
}
stent=$NV_DATA_DIR/stent/stent_128x128x256_int16.nhdr
for part in ${@:-frames state gui}; do
  case $part in
    frames)
      frames wavelet256 240
      [ -f "$stent" ] && frames stent 200 --data "$stent" ;;
    frames512)
      frames wavelet512 240 --n 512 ;;
    state)
      timeout 150 "$NV_PVBATCH" --force-offscreen-rendering "$bench/state_restore.py" "$NV_PLUGIN" "$out/state" \
        --source wavelet --n 256 --steps 300 --repeat 2 --device CUDA --stock > "$out/state_restore_gpu.log" 2>&1
      echo "state restore rc=$?"; grep RESULT "$out/state_restore_gpu.log" | tail -3 ;;
    gui)
      if [ -n "${NV_PARAVIEW:-}" ]; then
        # 1280x720 in ParaView's default window; 1920x1080 needs a larger one (its per-frame cost grows with it)
        NV_DATA_DIR=$NV_DATA_DIR NV_GUI_SAMPLE=1 NV_GUI_SIZES=1280x720 bash "$bench/gui_frames.sh" "$NV_PLUGIN" \
          "$out/gui" CUDA
        NV_DATA_DIR=$NV_DATA_DIR NV_GUI_SAMPLE=1 NV_GUI_SIZES=1920x1080 NV_GUI_GEOMETRY=2400x1500+0+0 \
          bash "$bench/gui_frames.sh" "$NV_PLUGIN" "$out/gui1080" CUDA
      else
        echo "gui: no GUI extras carried (.devcarry/gui-extras.tar.xz)"
      fi ;;
    guifull)
      NV_DATA_DIR=$NV_DATA_DIR NV_GUI_FULLSCREEN=1 NV_GUI_SIZES=1280x720,1920x1080 bash "$bench/gui_frames.sh" \
        "$NV_PLUGIN" "$out/guifull" CUDA ;;
  esac
done
