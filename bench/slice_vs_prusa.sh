#!/usr/bin/env bash
# Side by side: printtwin slice vs PrusaSlicer 2.5 on the same meshes and settings (the
# Ender-3 ini of ../shared/peers, 0.2 mm layers, 2 perimeters, 20 % infill), in one run.
# Reports median wall time of 3 runs (whole process), the ratio, layer count and filament.
# Needs prusa-slicer and openscad on PATH. Not a test: a cross-check and a benchmark.
#   bench/slice_vs_prusa.sh [build-dir] [prusa ini]
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
ini="${2:-$here/tests/data/slice/prusa_ender3.ini}"
pt="$build/src/printtwin"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# The meshes: 20 mm cube, cylinder (r 15, h 30, 256 sides), a ~200k-triangle model.
echo 'cube(20);' > "$work/cube.scad"
echo 'cylinder(r=15, h=30, $fn=256);' > "$work/cylinder.scad"
openscad -o "$work/cube20.stl" "$work/cube.scad" 2>/dev/null
openscad -o "$work/cylinder.stl" "$work/cylinder.scad" 2>/dev/null
# ~200k triangles: an OpenSCAD sphere with 450 segments (a closed, manifold mesh).
echo 'sphere(r=30, $fn=450);' > "$work/sphere.scad"
openscad -o "$work/sphere200k.stl" "$work/sphere.scad" 2>/dev/null
big="$work/sphere200k.stl"
models=("$work/cube20.stl" "$work/cylinder.stl" "$big")
extra=("${@:3}")
for m in "$here"/samples/models/thin_walls.stl "$here"/samples/models/calibration_cube_20mm.stl \
         "$here"/samples/models/curved_part.stl "$here"/samples/models/small_holes.stl \
         "$here"/samples/models/overhangs.stl; do
  [[ -f "$m" ]] && models+=("$m")
done

median3() { printf '%s\n' "$@" | sort -g | sed -n 2p; }
now() { date +%s.%N; }
layers() { grep -c '^;LAYER_CHANGE' "$1"; }
filament() { grep -m1 '^; filament used \[mm\]' "$1" | sed 's/.*= //'; }
# Filament of the part only (no start-code purge): sum of positive E of ;TYPE: extrusions
# other than Custom.
part_filament() {
  awk '/^;TYPE:/{t=substr($0,7)} /^G1 /&&/ E/&&(/ X/||/ Y/){for(i=1;i<=NF;i++) if(substr($i,1,1)=="E"){e=substr($i,2)+0; if(e>0&&t!="Custom") s+=e}} END{printf "%.1f", s}' "$1"
}

printf '| model | triangles | PrusaSlicer s | printtwin s | ratio | layers P/pt | filament P/pt (mm, part only) |\n'
printf '|---|---|---|---|---|---|---|\n'
for m in "${models[@]}"; do
  name="$(basename "$m" .stl)"
  tris=$(python3 -c "import struct,sys;d=open(sys.argv[1],'rb').read();print(struct.unpack('<I',d[80:84])[0] if not d.lstrip().startswith(b'solid') else d.count(b'facet normal'))" "$m")
  tp=(); tt=()
  for i in 1 2 3; do
    t0=$(now); prusa-slicer --load "$ini" --layer-height 0.2 --perimeters 2 --fill-density 20% \
      --center 110,110 --export-gcode -o "$work/$name.prusa.gcode" "$m" >/dev/null 2>&1; t1=$(now)
    tp+=("$(echo "$t1 - $t0" | bc -l)")
    t0=$(now); "$pt" slice "$m" -o "$work/$name.pt.gcode" --config "$ini" --layer-height 0.2 \
      --perimeters 2 --infill-density 20% --center 110,110 >/dev/null 2>&1; t1=$(now)
    tt+=("$(echo "$t1 - $t0" | bc -l)")
  done
  mp=$(median3 "${tp[@]}"); mt=$(median3 "${tt[@]}")
  printf '| %s | %s | %.2f | %.2f | %.2f | %s/%s | %s/%s |\n' "$name" "$tris" "$mp" "$mt" \
    "$(echo "$mt / $mp" | bc -l)" "$(layers "$work/$name.prusa.gcode")" "$(layers "$work/$name.pt.gcode")" \
    "$(part_filament "$work/$name.prusa.gcode")" "$(part_filament "$work/$name.pt.gcode")"
done
if [[ -n "${KEEP_GCODE:-}" ]]; then mkdir -p "$KEEP_GCODE"; cp "$work"/*.gcode "$KEEP_GCODE"/; fi
