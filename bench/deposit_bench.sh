#!/bin/sh
# Deposit benchmark: generates the ~200k-triangle model (openscad) and its G-code
# (PrusaSlicer, Ender-3 profile, 0.2 mm layers) under the build folder if missing, then runs
#   - bench/deposit_bench (raw voxel write rate, synthetic part, simulate + deposit, split)
#   - the whole CLI under /usr/bin/time (wall, user+sys, peak RSS)
# Usage: bench/deposit_bench.sh [build-dir]   (needs openscad and prusa-slicer installed)
set -eu
BUILD=${1:-build}
SRC=$(cd "$(dirname "$0")/.." && pwd)
DATA="$BUILD/benchdata"
mkdir -p "$DATA"
if [ ! -f "$DATA/deposit_model.gcode" ]; then
  openscad -o "$DATA/deposit_model.stl" "$SRC/bench/deposit_model.scad"
  prusa-slicer --load "$SRC/../shared/peers/prusa_ender3.ini" --layer-height 0.2 \
    --center 110,110 --export-gcode -o "$DATA/deposit_model.gcode" "$DATA/deposit_model.stl" ||
  prusa-slicer --load /work/shared/peers/prusa_ender3.ini --layer-height 0.2 \
    --center 110,110 --export-gcode -o "$DATA/deposit_model.gcode" "$DATA/deposit_model.stl"
fi
echo "triangles: $(grep -c 'facet normal' "$DATA/deposit_model.stl" 2>/dev/null || echo '?')"
echo "G-code lines: $(wc -l < "$DATA/deposit_model.gcode")"
grep "filament used \[mm\]" "$DATA/deposit_model.gcode" || true
PRINTTWIN_DEPOSIT_GCODE="$DATA/deposit_model.gcode" "$BUILD/bench/deposit_bench"
/usr/bin/time -v "$BUILD/src/printtwin" simulate "$DATA/deposit_model.gcode" --deposit-summary -q \
  2>&1 | grep -E "Elapsed|User time|System time|Maximum resident"
