#!/usr/bin/env bash
# CloudCompare's C2M from the as-printed mesh's vertices to the design, against verify's own
# deposit -> mesh figures (issue 24: mean and RMS within 5 %).
#
#   bench/mesh_c2m_compare.sh [MESH GCODE [extra verify options...]]
#       default: the 10 mm cube (-5..5, -5..5, 0..10; made with openscad) and
#       samples/gcode/prusa_cube10.gcode
#
# 1. `printtwin verify MESH --gcode GCODE --deposit-mesh asprinted.ply`: verify's deposit ->
#    mesh figures (report.json: deviation.deposit_to_mesh mean_mm, rms_mm; area-weighted
#    over the deposit's outer surface) and the as-printed mesh.
# 2. `deviation_bench --export`: the design placed in the G-code frame (mesh.stl), as verify
#    places it.
# 3. CloudCompare 2.11: `CloudCompare -SILENT -AUTO_SAVE OFF -O vertices.ply -O mesh.stl
#    -C2M_DIST -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE cc.asc` (vertices.ply: the as-printed
#    mesh's vertices as a point cloud, in file order).
# 4. The same C2M from points spread uniformly over the mesh's surface (mesh_c2m_stats.py
#    surface: one per SURFACE_SPACING_MM^2 on average, default 0.05 mm, fixed seed): the
#    mean over the surface whatever the triangulation (a long rectangle's fan puts most of
#    its area on a few corner vertices).
# 5. bench/mesh_c2m_stats.py: mean and RMS of CloudCompare's signed distances, per vertex
#    (as CloudCompare shows them) and weighted by each vertex's area (a third of the
#    triangles around it: the surface integral over the mesh, which is what verify's figure
#    is), against verify's; then where they differ: per band of layers and per kind of mesh
#    surface (side, caps up, caps down), the surface points' C2M against verify's per-layer
#    figures (mesh_c2m_stats.py regions).
# 6. CloudCompare's C2M of verify's own deposit samples (points.ply) against the surface
#    points' per kind of surface (mesh_c2m_stats.py kinds: the bed, the first layer's sides,
#    the other sides, the top two layers' caps, the other caps; VERIFY_STRIDE=N takes every
#    N-th sample): where the per-layer figures mix the bed into the first layer and the sides
#    into the top, this compares like with like.
# KEEP_DIR=DIR keeps every file (as-printed mesh, points, CloudCompare's distances, report).
# Needs CloudCompare and openscad (../shared/peers); run from the repository root after building. Re-run it
# after a change to verify's sampling: it reads verify's figures, it does not keep them.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${BUILD_DIR:-$root/build}" && pwd)"
mesh="${1:-}"
gcode="${2:-$root/samples/gcode/prusa_cube10.gcode}"
shift $(( $# > 2 ? 2 : $# ))
if [ -n "${KEEP_DIR:-}" ]; then  # keep the files (mesh, points, distances, report) there
  mkdir -p "$KEEP_DIR"
  work="$(cd "$KEEP_DIR" && pwd)"
else
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
fi
if [ -z "$mesh" ]; then  # the cube PrusaSlicer sliced for prusa_cube10.gcode (OpenSCAD)
  echo 'translate([-5, -5, 0]) cube(10);' > "$work/cube10.scad"
  openscad -o "$work/cube10.stl" "$work/cube10.scad" > /dev/null 2>&1
  mesh="$work/cube10.stl"
fi
"$build/src/printtwin" verify "$mesh" --gcode "$gcode" --out "$work/report" \
  --deposit-mesh "$work/asprinted.ply" "$@" > "$work/verify.log" 2>&1 || true
grep -E "^deposit mesh|smoothed|not smoothed" "$work/verify.log" || { cat "$work/verify.log"; exit 1; }
"$build/bench/deviation_bench" --export "$mesh" "$gcode" "$work" > /dev/null
python3 "$root/bench/mesh_c2m_stats.py" vertices "$work/asprinted.ply" "$work/vertices.ply"
QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O "$work/vertices.ply" \
  -O "$work/mesh.stl" -C2M_DIST -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/cc.asc" \
  > "$work/cc.log" 2>&1
python3 "$root/bench/mesh_c2m_stats.py" surface "$work/asprinted.ply" "$work/surface.ply" \
  "${SURFACE_SPACING_MM:-0.05}"
QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O "$work/surface.ply" \
  -O "$work/mesh.stl" -C2M_DIST -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/cc_surface.asc" \
  > "$work/cc_surface.log" 2>&1
python3 "$root/bench/mesh_c2m_stats.py" compare "$work/asprinted.ply" "$work/cc.asc" \
  "$work/report/report.json" "$work/cc_surface.asc"
python3 "$root/bench/mesh_c2m_stats.py" regions "$work/asprinted.ply" "$work/cc_surface.asc" \
  "$work/report/report.json" "${SURFACE_SPACING_MM:-0.05}" "${BANDS:-8}"
QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O "$work/points.ply" \
  -O "$work/mesh.stl" -C2M_DIST -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/cc_verify.asc" \
  > "$work/cc_verify.log" 2>&1
python3 "$root/bench/mesh_c2m_stats.py" kinds "$work/asprinted.ply" "$work/cc_surface.asc" \
  "$work/cc_verify.asc" "${SURFACE_SPACING_MM:-0.05}" "${VERIFY_STRIDE:-1}"
