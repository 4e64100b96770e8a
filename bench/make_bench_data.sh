#!/bin/sh
# Builds the benchmark inputs once, under <build-dir>/benchdata/:
#   bench_model.stl    bench/bench_model.scad rendered by OpenSCAD (ASCII STL, 200,996 triangles)
#   bench_model.gcode  PrusaSlicer's G-code for it (../shared/peers/prusa_ender3.ini, 0.2 mm
#                      layers, centred at 110,110)
# and prints their sizes. Needs prusa-slicer (../shared/peers/README.md), and openscad or
# python3 (without openscad, bench/bench_model_stl.py writes the same part).
# Usage: bench/make_bench_data.sh [build-dir]
set -eu
BUILD=${1:-build}
SRC=$(cd "$(dirname "$0")/.." && pwd)
DATA="$BUILD/benchdata"
INI="$SRC/../shared/peers/prusa_ender3.ini"
[ -f "$INI" ] || INI=/work/shared/peers/prusa_ender3.ini
mkdir -p "$DATA"
if [ ! -f "$DATA/bench_model.stl" ]; then
  if command -v openscad > /dev/null; then
    openscad -o "$DATA/bench_model.stl" "$SRC/bench/bench_model.scad" 2> "$DATA/openscad.log"
  else  # the same part written by a script (4 more cap triangles)
    python3 "$SRC/bench/bench_model_stl.py" "$DATA/bench_model.stl"
  fi
fi
if [ ! -f "$DATA/bench_model.gcode" ]; then
  prusa-slicer --load "$INI" --layer-height 0.2 --center 110,110 \
    --export-gcode -o "$DATA/bench_model.gcode" "$DATA/bench_model.stl" > "$DATA/prusa-slicer.log" 2>&1
fi
echo "bench model: $(grep -c 'facet normal' "$DATA/bench_model.stl") triangles," \
  "$(wc -l < "$DATA/bench_model.gcode") G-code lines," \
  "$(sed -n 's/^; filament used \[mm\] = //p' "$DATA/bench_model.gcode") mm of filament"
