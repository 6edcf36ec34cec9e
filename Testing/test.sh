#!/usr/bin/env bash
# The test command: installs what is missing, builds, and runs every test (engine, gpu [skipped without a GPU],
# paraview) under one Xvfb server.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${NV_BUILD_DIR:-$root/build}
"$root/Testing/setup.sh"
cd "$build"
xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" \
  ctest --output-on-failure -j "$(nproc)" --timeout 1200 "$@"
