# Sourced by run_paraview_gpu.sh and run_paraview_gpu_bench.sh on the device machine: unpacks Debian's ParaView
# (.devcarry/pvrt parts, once, into .devcarry/pvrt-root) and the plugin (.devcarry/plugin.tar.xz), puts pvserver
# (.devcarry/bin/pvserver, carried from this machine: the packed runtime lacks it) beside pvbatch, starts Xvfb :57
# with NVIDIA's GLX, and exports what the tests read (NV_PLUGIN, NV_TEST_OUTPUT, NV_PVBATCH, ...).
here=$(pwd)
root=$here/.devcarry/pvrt-root
out=$here/.devcarry/gpu-paraview-out   # pictures stay there while the machine is held

mkdir -p "$out"
if [ ! -f "$root/env.sh" ]; then
  bash "$here/.devcarry/unpack.sh" "$here/.devcarry/pvrt" "$root" > "$out/unpack.log" 2>&1 || { cat "$out/unpack.log"; exit 1; }
fi
if [ ! -d "$here/.devcarry/plugin/NeuralVolume" ]; then
  mkdir -p "$here/.devcarry/plugin" && tar -xJf "$here/.devcarry/plugin.tar.xz" -C "$here/.devcarry/plugin"
fi
[ -e "$root/usr/bin/pvserver" ] || [ ! -f "$here/.devcarry/bin/pvserver" ] || install -m 755 "$here/.devcarry/bin/pvserver" "$root/usr/bin/pvserver"
# shellcheck disable=SC1091
source "$root/env.sh"
# The GUI's extras (Qt's X11 platform plugins, xdotool; Testing/Gpu/pack_gui_extras.sh), when carried
if [ -f "$here/.devcarry/gui-extras.tar.xz" ]; then
  [ -d "$here/.devcarry/gui-root/gui" ] || { mkdir -p "$here/.devcarry/gui-root" &&
    tar -xJf "$here/.devcarry/gui-extras.tar.xz" -C "$here/.devcarry/gui-root"; }
  gui=$here/.devcarry/gui-root/gui
  export PATH=$gui/bin:$PATH QT_PLUGIN_PATH=$gui/qt5/plugins LD_LIBRARY_PATH=$LD_LIBRARY_PATH:$gui/lib
  export NV_PARAVIEW=$root/usr/bin/paraview NV_HOST_PYTHON=$root/usr/bin/python3.11 # the runtime's own (PYTHONHOME)
fi
# Open MPI (Testing/Gpu/pack_mpi_extras.sh), when carried: mpiexec for run_paraview_gpu_mpi.sh. Debian's Open MPI finds
# its components relative to OPAL_PREFIX; its /etc/openmpi settings (no ofi, ucx) come from the carried copy.
if [ -f "$here/.devcarry/mpi-extras.tar.xz" ]; then
  [ -d "$here/.devcarry/mpi-root/mpi" ] || { mkdir -p "$here/.devcarry/mpi-root" &&
    tar -xJf "$here/.devcarry/mpi-extras.tar.xz" -C "$here/.devcarry/mpi-root"; }
  mpi=$here/.devcarry/mpi-root/mpi
  export OPAL_PREFIX=$mpi/usr PATH=$mpi/usr/bin:$PATH
  export LD_LIBRARY_PATH=$LD_LIBRARY_PATH:$mpi/lib:$mpi/usr/lib/x86_64-linux-gnu/pmix2/lib
  export OMPI_MCA_mca_base_param_files=$mpi/etc/openmpi/openmpi-mca-params.conf
  export PMIX_MCA_mca_base_component_path=$mpi/usr/lib/x86_64-linux-gnu/pmix2/lib/pmix
  export NV_MPIEXEC=$mpi/usr/bin/orterun
fi
plugin_dir=$here/.devcarry/plugin/NeuralVolume
export LD_LIBRARY_PATH=$plugin_dir:$LD_LIBRARY_PATH
export __GLX_VENDOR_LIBRARY_NAME=nvidia PYTHONUNBUFFERED=1
export NV_PLUGIN=$plugin_dir/NeuralVolume.so NV_TEST_OUTPUT=$out NV_PVBATCH=$root/usr/bin/pvbatch
export NV_DATA_DIR=$here/.devcarry/data NV_BASELINE_DIR=$here/Testing/ParaView/Baseline
pgrep -f "Xvfb :57" > /dev/null || { Xvfb :57 -screen 0 2560x1600x24 -nolisten tcp -xkbdir "$NV_XKB_DIR" > "$out/xvfb.log" 2>&1 & sleep 2; }
export DISPLAY=:57
nvidia-smi --query-gpu=name,driver_version --format=csv > "$out/gpu.txt"
