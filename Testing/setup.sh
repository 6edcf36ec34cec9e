#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks, then configures and builds NeuralVolume into build/.
# Used by Testing/test.sh and Testing/demo.sh. NV_BUILD_DIR overrides the build folder.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${NV_BUILD_DIR:-$root/build}

pkgs=(paraview paraview-dev python3-paraview xvfb xauth libopenmpi-dev libdouble-conversion-dev libglew-dev
      libopenvdb-dev libboost-iostreams-dev cmake ninja-build g++ make clang libclang-rt-14-dev python3-pip
      python3-matplotlib qtbase5-dev qttools5-dev qtxmlpatterns5-dev-tools xdotool imagemagick
      libhdf5-openmpi-dev python3-h5py)  # HDF5: out-of-core .h5 datasets (the library of ParaView's VTK) and the test's files
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q "${missing[@]}"
fi

# The run-time-versus-error harness (Testing/Benchmarks/tradeoff.py) compares with ZFP and SZ3: their Python wheels,
# into the build folder (Debian's Python refuses system-wide pip installs).
if [ ! -d "$build/pydeps/pysz" ] || [ ! -d "$build/pydeps/zfpy.libs" ]; then
  mkdir -p "$build"
  /usr/bin/python3 -m pip install -q --disable-pip-version-check --no-deps --target "$build/pydeps" \
    pysz==1.1.0 zfpy==1.0.1.post0
fi

if [ ! -f "$build/build.ninja" ]; then
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$build" -j "$(nproc)"
