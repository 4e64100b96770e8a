#!/usr/bin/env bash
# Regenerates the G-code fixtures in samples/gcode/ from the sample models with the peer
# slicers (PrusaSlicer 2.5, CuraEngine 4.13, Slic3r 1.3) and records the slicers' own figures
# (PrusaSlicer's time estimate and filament, CuraEngine -v's time and filament) in
# samples/gcode/peer_figures.json. The tests read these files; they never run the slicers.
#
#   scripts/make_gcode_fixtures.sh            # needs prusa-slicer, CuraEngine, slic3r
#
# Files are kept < 100 KB each: the 20 mm cube is sliced at half scale (10 mm cube).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
peers="${PEERS_DIR:-$root/../shared/peers}"
[ -d "$peers" ] || peers=/work/shared/peers
models="$root/samples/models"
out="$root/samples/gcode"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# --- PrusaSlicer 2.5 (machine_limits_usage = time_estimate_only: limits only in the config block)
prusa() {  # name model scale layer_height [more options]
  prusa-slicer --load "$peers/prusa_ender3.ini" --layer-height "$4" --scale "$3" "${@:5}" \
    --center 110,110 --export-gcode -o "$out/$1.gcode" "$models/$2" >/dev/null
}
prusa prusa_cube10 calibration_cube_20mm.stl 0.5 0.2
prusa prusa_thin_walls thin_walls.stl 1 0.3
prusa prusa_curved_part curved_part.stl 0.3 0.3
# Spiral vase: one ;LAYER_CHANGE per turn while Z rises along every extrusion.
prusa prusa_vase10 calibration_cube_20mm.stl 0.5 0.2 --spiral-vase --perimeters 1 \
  --top-solid-layers 0 --fill-density 0

# --- Slic3r 1.3 (its end G-code leaves `G1 Z[next_layer_z]` unexpanded: kept on purpose)
slic3r --load "$peers/slic3r_ender3.ini" --layer-height 0.3 --scale 0.5 --print-center 110,110 \
  -o "$out/slic3r_cube10.gcode" "$models/calibration_cube_20mm.stl" >/dev/null

# --- CuraEngine 4.13: every setting passed with -s (the CLI ignores the .def.json formulas).
cura_defs=/usr/share/cura/resources
export CURA_ENGINE_SEARCH_PATH="$cura_defs/definitions:$cura_defs/extruders"
cura() {  # name model scale
  local stl="$tmp/$2"
  if [ "$3" != 1 ]; then  # CuraEngine has no scale option: scale with OpenSCAD
    echo "scale($3) import(\"$models/$2\");" > "$tmp/scale.scad"
    openscad -o "$stl" "$tmp/scale.scad" 2>/dev/null
  else
    cp "$models/$2" "$stl"
  fi
  CuraEngine slice -v -j "$cura_defs/definitions/creality_ender3.def.json" \
    -s machine_width=235 -s machine_depth=235 -s machine_height=250 \
    -s machine_center_is_zero=false -s machine_gcode_flavor="RepRap (Marlin/Sprinter)" \
    -s machine_nozzle_size=0.4 -s material_diameter=1.75 -s layer_height=0.2 \
    -s layer_height_0=0.2 -s line_width=0.4 -s wall_line_width=0.4 -s wall_line_width_0=0.4 \
    -s wall_line_width_x=0.4 -s skin_line_width=0.4 -s infill_line_width=0.4 \
    -s initial_layer_line_width_factor=100 -s skirt_brim_line_width=0.4 \
    -s wall_line_count=2 -s wall_thickness=0.8 -s top_layers=4 -s bottom_layers=4 \
    -s top_thickness=0.8 -s bottom_thickness=0.8 -s infill_sparse_density=20 \
    -s infill_pattern=grid -s infill_line_distance=4 -s adhesion_type=skirt -s skirt_line_count=1 \
    -s skirt_gap=3 -s speed_print=50 -s speed_infill=50 -s speed_wall=25 -s speed_wall_0=25 \
    -s speed_wall_x=25 -s speed_topbottom=25 -s speed_travel=150 -s speed_layer_0=20 \
    -s speed_print_layer_0=20 -s speed_travel_layer_0=100 -s skirt_brim_speed=20 \
    -s retraction_enable=true -s retraction_amount=5 -s retraction_speed=45 \
    -s retraction_retract_speed=45 -s retraction_prime_speed=45 -s retraction_hop_enabled=false \
    -s material_print_temperature=200 -s material_print_temperature_layer_0=200 \
    -s material_initial_print_temperature=200 -s material_final_print_temperature=200 \
    -s material_bed_temperature=60 -s material_bed_temperature_layer_0=60 \
    -s cool_fan_enabled=true -s cool_fan_speed=100 -s cool_min_layer_time=0 \
    -s acceleration_enabled=false -s jerk_enabled=false -s magic_spiralize=false \
    -s support_enable=false -s center_object=true -s mesh_position_x=0 -s mesh_position_y=0 \
    -l "$stl" -o "$out/$1.gcode" 2> "$tmp/$1.log"
  # With -v CuraEngine prints ";TIME:N", ";Filament used: Lm" and "Filament (mm^3): V" on
  # stderr (the file's own header keeps the placeholders).
  local t l v
  t="$(grep -m1 -o '^;TIME:[0-9.]*' "$tmp/$1.log" | cut -d: -f2)"
  l="$(grep -m1 -o '^;Filament used: [0-9.]*' "$tmp/$1.log" | awk '{print $3}')"
  v="$(grep -m1 -o 'Filament (mm^3): [0-9.]*' "$tmp/$1.log" | awk '{print $3}')"
  echo "$1 $t $l $v" >> "$tmp/cura_figures.txt"
}
: > "$tmp/cura_figures.txt"
cura cura_cube10 calibration_cube_20mm.stl 0.5

# --- The slicers' own figures, next to the fixtures.
python3 - "$out" "$tmp/cura_figures.txt" <<'PY'
import json, math, re, sys, pathlib
out = pathlib.Path(sys.argv[1])
figures = {"schema": "printtwin.peer_figures/1", "files": {}}
def hms(s):
    t = 0
    for n, u in re.findall(r"(\d+)([dhms])", s):
        t += int(n) * {"d": 86400, "h": 3600, "m": 60, "s": 1}[u]
    return t
for g in sorted(out.glob("prusa_*.gcode")):
    text = g.read_text()
    est = re.search(r"; estimated printing time \(normal mode\) = (.*)", text).group(1)
    fil = float(re.search(r"; filament used \[mm\] = ([0-9.]+)", text).group(1))
    figures["files"][g.name] = {"slicer": "PrusaSlicer 2.5.0",
                                "estimated_time_normal_s": hms(est),
                                "filament_mm": fil,
                                "layers": text.count(";LAYER_CHANGE\n")}
for line in pathlib.Path(sys.argv[2]).read_text().split("\n"):
    if not line.strip():
        continue
    name, t, length_m, v = line.split()
    figures["files"][name + ".gcode"] = {"slicer": "CuraEngine 4.13",
                                         "print_time_s": float(t),
                                         "filament_mm": round(float(length_m) * 1000, 3),
                                         "filament_mm3": float(v)}
(out / "peer_figures.json").write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")
PY
ls -l "$out"
