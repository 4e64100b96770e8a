#!/usr/bin/env bash
# Agreement and speed of printtwin's deposit -> mesh distances against CloudCompare's C2M.
#
#   bench/c2m_compare.sh [MESH GCODE]      (default: the 10 mm cube sample and its PrusaSlicer
#                                           G-code; pass e.g. a 200k-triangle model and the
#                                           G-code PrusaSlicer made for it)
#
# 1. `deviation_bench --export` runs printtwin verify and writes the deposit's outer-surface
#    points (exposed voxel-face centres, binary PLY, doubles) and the mesh placed in the
#    G-code frame (STL).
# 2. Whole process, same points and mesh:
#      ours: `deviation_bench --c2m points.ply mesh.stl`
#      CloudCompare 2.11: `CloudCompare -SILENT -AUTO_SAVE OFF -O points.ply -O mesh.stl
#                          -C2M_DIST -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE cc.asc`
#    (median of 3 wall times each).
# 3. bench/c2m_stats.py compares mean, RMS and max of |d| (goal: within 1e-4 mm) and prints
#    the speed ratio (goal: ours >= 5x faster).
# Needs CloudCompare (../shared/peers); run from the repository root after building.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${BUILD_DIR:-$root/build}" && pwd)"  # absolute: the script changes folder
bench="$build/bench/deviation_bench"
mesh="${1:-}"
gcode="${2:-$root/samples/gcode/prusa_cube10.gcode}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
if [ -z "$mesh" ]; then  # the cube PrusaSlicer sliced for prusa_cube10.gcode, built here
  python3 - "$work/cube10.stl" <<'PY'
import sys
lo, hi = (-5, -5, 0), (5, 5, 10)
v = [(hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2]) for i in range(8)]
t = [(0,2,1),(1,2,3),(4,5,6),(5,7,6),(0,1,4),(1,5,4),(2,6,3),(3,6,7),(0,4,2),(2,4,6),(1,3,5),(3,7,5)]
with open(sys.argv[1], "w") as f:
    f.write("solid cube\n")
    for tri in t:
        f.write("facet normal 0 0 0\nouter loop\n" + "".join("vertex %g %g %g\n" % v[i] for i in tri) + "endloop\nendfacet\n")
    f.write("endsolid cube\n")
PY
  mesh="$work/cube10.stl"
fi
"$bench" --export "$mesh" "$gcode" "$work"

median3() {  # median wall time of 3 runs of "$@", seconds
  local times=()
  for _ in 1 2 3; do
    local t0 t1
    t0=$(date +%s.%N); "$@" > /dev/null 2>&1; t1=$(date +%s.%N)
    times+=("$(echo "$t1 - $t0" | bc -l)")
  done
  printf '%s\n' "${times[@]}" | sort -g | sed -n 2p
}
cd "$work"
ours_out="$("$bench" --c2m points.ply mesh.stl)"
QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O points.ply -O mesh.stl -C2M_DIST \
  -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE cc.asc > cc.log 2>&1
t_ours=$(median3 "$bench" --c2m points.ply mesh.stl)
t_cc=$(median3 env QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O points.ply \
  -O mesh.stl -C2M_DIST -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE cc2.asc)
python3 "$root/bench/c2m_stats.py" cc.asc "$ours_out" "$t_ours" "$t_cc"
