#!/bin/sh
# Repair counters side by side: `printtwin check --repair` against admesh (default: every fix)
# on the same broken files. Builds seven small cases (a 20 mm cube with one defect each) and
# adds the files given on the command line. Prints one Markdown row per file and tool.
#   bench/repair_vs_admesh.sh [build-dir] [file.stl...]        (default build-dir: build)
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
[ $# -gt 0 ] && shift
cli="$build/src/printtwin"
command -v admesh >/dev/null || { echo "repair_vs_admesh: admesh is not installed" >&2; exit 2; }
[ -x "$cli" ] || { echo "repair_vs_admesh: build printtwin_cli in $build first" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# cube CASE > file: the 20 mm cube (12 outward facets) with one defect:
#   flipped (facet 1 wound the other way), hole (facet 12 left out), duplicate (facet 4
#   again at the end), inverted (every facet the other way), seam (the top's corners 0.001
#   mm off), crack (one corner of the top 0.002 mm higher), tjunction (the top a fan of three
#   facets from a vertex in the middle of its edge with the +x side, whose facet keeps that
#   edge whole). Stored normals follow each facet's winding.
cube() {
  awk -v c="$1" '
  function facet(a, b, d,    i, p, q, r, nx, ny, nz, l) {
    split(V[a], p, " "); split(V[b], q, " "); split(V[d], r, " ")
    if (c == "seam" && top) { p[1] += 0.001; q[1] += 0.001; r[1] += 0.001 }
    if (c == "crack" && top) { if (a == 7) p[3] += 0.002; if (b == 7) q[3] += 0.002; if (d == 7) r[3] += 0.002 }
    nx = (q[2]-p[2])*(r[3]-p[3]) - (q[3]-p[3])*(r[2]-p[2])
    ny = (q[3]-p[3])*(r[1]-p[1]) - (q[1]-p[1])*(r[3]-p[3])
    nz = (q[1]-p[1])*(r[2]-p[2]) - (q[2]-p[2])*(r[1]-p[1])
    l = sqrt(nx*nx + ny*ny + nz*nz)
    printf " facet normal %g %g %g\n  outer loop\n", nx/l, ny/l, nz/l
    printf "   vertex %g %g %g\n   vertex %g %g %g\n   vertex %g %g %g\n", p[1], p[2], p[3], q[1], q[2], q[3], r[1], r[2], r[3]
    print "  endloop\n endfacet"
  }
  BEGIN {
    split("0 0 0|20 0 0|20 20 0|0 20 0|0 0 20|20 0 20|20 20 20|0 20 20|20 10 20", V, "|")
    split("1 3 2|1 4 3|5 6 7|5 7 8|1 2 6|1 6 5|2 3 7|2 7 6|3 4 8|3 8 7|4 1 5|4 5 8", T, "|")
    print "solid " c
    for (k = 1; k <= 12; k++) {
      if ((c == "hole" && k == 12) || (c == "tjunction" && (k == 3 || k == 4))) continue
      split(T[k], t, " ")
      top = (k == 3 || k == 4)
      if ((c == "flipped" && k == 1) || c == "inverted") facet(t[1], t[3], t[2])
      else facet(t[1], t[2], t[3])
    }
    if (c == "duplicate") { split(T[4], t, " "); top = 1; facet(t[1], t[2], t[3]) }
    if (c == "tjunction") { top = 0; facet(9, 7, 8); facet(9, 8, 5); facet(9, 5, 6) }
    print "endsolid " c
  }'
}

files=""
for c in flipped hole duplicate inverted seam crack tjunction; do
  cube "$c" > "$tmp/cube_$c.stl"
  files="$files $tmp/cube_$c.stl"
done
files="$files $*"

echo "| file | tool | edges fixed | facets removed | facets added | facets reversed | backwards edges | holes filled / normals fixed | parts |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
for f in $files; do
  name=$(basename "$f")
  "$cli" check "$f" --repair "$tmp/repaired.stl" 2>/dev/null | awk -v n="$name" '
    /^           edges fixed/ {
      gsub(/,/, ""); printf "| %s | printtwin | %s | %s | %s | %s | %s | %s holes | %s |\n", n, $3, $6, $9, $12, $15, $18, $23 }'
  admesh "$f" 2>/dev/null | awk -v n="$name" -F: '
    /^Edges fixed/ { e = $2 } /^Facets removed/ { r = $2 } /^Facets added/ { a = $2 }
    /^Facets reversed/ { v = $2 } /^Backwards edges/ { b = $2 } /^Normals fixed/ { nf = $2 }
    /^Number of parts/ { split($2, q, " "); p = q[1] }
    END { gsub(/ /, "", e); gsub(/ /, "", r); gsub(/ /, "", a); gsub(/ /, "", v); gsub(/ /, "", b); gsub(/ /, "", nf)
          printf "| %s | admesh | %s | %s | %s | %s | %s | %s normals | %s |\n", n, e, r, a, v, b, nf, p }'
done
