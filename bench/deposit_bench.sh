#!/bin/sh
# Deposit benchmark on the issues' benchmark part (bench/bench_model.scad: 201k triangles;
# PrusaSlicer G-code of ~156k lines and 4.7 m of filament), generated once under
# <build-dir>/benchdata by bench/make_bench_data.sh (needs openscad and prusa-slicer). Runs
#   - bench/deposit_bench: raw voxel write rate, synthetic part, simulate + deposit, deposit
#     alone (with a checksum of every voxel and tag), overlap by feature group
#   - the CLI under /usr/bin/time: simulate + deposit, and the same writing OctoMap .bt
#     and .ot (CPU time = user + sys, peak RSS), and PrusaSlicer slicing the same part with
#     the profile that made the G-code, for the side-by-side ratio
# Usage: bench/deposit_bench.sh [build-dir]
set -eu
BUILD=${1:-build}
SRC=$(cd "$(dirname "$0")/.." && pwd)
sh "$SRC/bench/make_bench_data.sh" "$BUILD"
GCODE="$BUILD/benchdata/bench_model.gcode"
PRINTTWIN_DEPOSIT_GCODE="$GCODE" "$BUILD/bench/deposit_bench"
OUT=$(mktemp -d)
echo "simulate + deposit (one core):"
/usr/bin/time -f "  %e s wall, %U s user, %S s sys, %M KB peak RSS" \
  "$BUILD/src/printtwin" simulate "$GCODE" --deposit-summary -q
echo "simulate + deposit + OctoMap .bt:"
/usr/bin/time -f "  %e s wall, %U s user, %S s sys, %M KB peak RSS" \
  "$BUILD/src/printtwin" simulate "$GCODE" --deposit "$OUT/bench_model.bt" -q
ls -l "$OUT/bench_model.bt" | awk '{print "  .bt file: " $5 " bytes"}'
echo "simulate + deposit + OctoMap .ot (by layer):"
/usr/bin/time -f "  %e s wall, %U s user, %S s sys, %M KB peak RSS" \
  "$BUILD/src/printtwin" simulate "$GCODE" --deposit "$OUT/bench_model.ot" -q
ls -l "$OUT/bench_model.ot" | awk '{print "  .ot file: " $5 " bytes"}'
INI="$SRC/../shared/peers/prusa_ender3.ini"
[ -f "$INI" ] || INI=/work/shared/peers/prusa_ender3.ini
if command -v prusa-slicer > /dev/null && [ -f "$INI" ]; then
  echo "PrusaSlicer slicing the same part (make_bench_data.sh's command):"
  /usr/bin/time -f "  %e s wall, %U s user, %S s sys, %M KB peak RSS" \
    prusa-slicer --load "$INI" --layer-height 0.2 --center 110,110 --export-gcode \
    -o "$OUT/prusa.gcode" "$BUILD/benchdata/bench_model.stl" > /dev/null 2> "$OUT/prusa.log" ||
    tail -3 "$OUT/prusa.log"
  tail -1 "$OUT/prusa.log"
fi
rm -rf "$OUT"
