#!/usr/bin/env bash
# The rate-distortion table of issue 25 (results/rd_table_2026-11-27.md, .csv and rd_table_2026-11-27/rd_*.png),
# regenerated on the CPU machine from the committed CSVs. Usage: rd_table.sh [GPU_OUT...]
# GPU_OUT: folders with run_rd_gpu.sh's $OUT (net512/, torch512/, seeds/ with tradeoff.csv each). With them, the CSVs are copied
# into results/rd_table_2026-11-27/ (net512.csv, torch512.csv, seeds.csv), the 512^3 volumes are generated here
# (tradeoff_volumes.py, seed 1, into $VOLS, default /tmp/nv_rd_volumes; compare the sha256 lines with the device's),
# and SZ3 (ABS and PSNR modes) is bisected at the GPU run's network ratios not searched yet (the 8-bit ones), its rows
# appended to codecs_512.csv: about 10 minutes per ratio and volume on 2 busy cores (NO_SZ3=1 skips it: the new
# ratios are then compared with ZFP only).
# PYTHONPATH: the zfpy/pysz wheels of Testing/setup.sh (build/pydeps; NV_PYDEPS overrides).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
R=$here/results
RD=$R/rd_table_2026-11-27
py=/usr/bin/python3
export PYTHONPATH=${NV_PYDEPS:-$here/../../build/pydeps}
if [ $# -ge 1 ]; then
  for dir in "$@"; do for part in net512 torch512 seeds; do
    if [ -f "$dir/$part/tradeoff.csv" ]; then cp "$dir/$part/tradeoff.csv" "$RD/$part.csv"; fi
  done; done
  if [ -f "$RD/net512.csv" ] && [ -z "${NO_SZ3:-}" ]; then
    V=${VOLS:-/tmp/nv_rd_volumes}
    [ -f "$V/rmmixing_512_float.nhdr" ] || $py "$here/tradeoff_volumes.py" "$V" --size 512 --seed 1
    rm -rf "$V/sz3"
    $py "$here/tradeoff.py" compressors --codecs sz3 --sz3-modes abs,psnr --out "$V/sz3" \
      --volumes "$V"/*_512_float.nhdr --targets-from "$RD/net512.csv" --skip-targets-in $(ls "$RD/codecs_512.csv" 2>/dev/null)
    if [ -f "$RD/codecs_512.csv" ]; then tail -n +2 "$V/sz3/tradeoff.csv" >> "$RD/codecs_512.csv"
    else cp "$V/sz3/tradeoff.csv" "$RD/codecs_512.csv"; fi
  fi
fi
csvs=("$RD/codecs_data.csv" "$R/tradeoff_2026-11-25/neural_gpu.csv")
for part in codecs_512 net512 torch512 seeds; do [ -f "$RD/$part.csv" ] && csvs+=("$RD/$part.csv"); done
$py "$here/tradeoff_table.py" "${csvs[@]}" --legacy-seeds "$R/tradeoff_2026-11-25/seeds_results.csv" \
  --md "$R/rd_table_2026-11-27.md" --csv-out "$R/rd_table_2026-11-27.csv" --plots "$RD" \
  --readme "$here/../../README.md" > /dev/null
echo "rd_table: $R/rd_table_2026-11-27.md, $R/rd_table_2026-11-27.csv, plots in $RD"
