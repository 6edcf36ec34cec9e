#!/usr/bin/env bash
# The GUI's frame rate while the view turns and Neural Compress trains (issue 24): runs gui_frames_script.py inside
# the real paraview (an X display and xdotool needed; on the device machine run_paraview_gpu_bench.sh calls it with
# Debian's ParaView unpacked there and NVIDIA's GL). usage: gui_frames.sh PLUGIN OUT_DIR [CUDA|CPU] [small]
# NV_GUI_GEOMETRY: the main window's size (Qt's -geometry, e.g. 2400x1500+0+0: room for a 1920 x 1080 preview).
#   here, a quick run:  xvfb-run -a -s "-screen 0 2560x1600x24" bash Testing/Benchmarks/gui_frames.sh \
#                         build/lib/paraview-plugins/NeuralVolume/NeuralVolume.so /tmp/gui-frames CPU small
set -u
here=$(cd "$(dirname "$0")/../.." && pwd)
export NV_PLUGIN=$1 NV_TEST_OUTPUT=$2 NV_GUI_DEVICE=${3:-CUDA} NV_TEST_DIR=$here/Testing/ParaView
[ "${4:-}" = small ] && export NV_GUI_SMALL=1
mkdir -p "$NV_TEST_OUTPUT"
timeout 300 "${NV_PARAVIEW:-paraview}" --dr ${NV_GUI_GEOMETRY:+-geometry $NV_GUI_GEOMETRY} --script="$here/Testing/Benchmarks/gui_frames_script.py" \
  > "$NV_TEST_OUTPUT/gui_frames.log" 2>&1
rc=$?
echo "gui frames rc=$rc"; grep -E "still view|: \{|never" "$NV_TEST_OUTPUT/gui_frames.log" | cut -c1-400
exit $rc
