#!/bin/sh
# A folder of 40 STLs (the samples plus 34 OpenSCAD parts of about 1k to 250k triangles)
# checked in one `printtwin check DIR --summary --junit` run, against admesh run on each file
# in turn (its default checks). printtwin checks the parts in parallel on every core (the
# core count is printed), admesh is one single-threaded process per file. Runs alternate
# between the tools; the median of RUNS (3) wall-clock runs each, and its user+sys CPU.
#   [FORMAT=binary] [RUNS=n] [BASE=other-build-dir] bench/check_batch_vs_admesh.sh [build-dir] [parts-dir]
# BASE times a second build's printtwin in the same alternation (before/after a change).
# parts-dir is kept when given (made when missing), else a temporary folder is used.
# OpenSCAD writes ASCII STL; FORMAT=binary times binary copies of the same parts instead
# (written by `admesh -c -b`, no check or fix).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
cli="$build/src/printtwin"
for tool in admesh openscad; do
  command -v "$tool" >/dev/null || { echo "check_batch_vs_admesh: $tool is not installed" >&2; exit 2; }
done
[ -x "$cli" ] || { echo "check_batch_vs_admesh: build printtwin_cli in $build first" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
parts=${2:-$tmp/parts}
if [ ! -d "$parts" ] || [ -z "$(ls "$parts")" ]; then
  mkdir -p "$parts"
  cp "$here"/samples/models/*.stl "$parts/"
  # scad BODY NAME: renders one part.
  scad() { printf '%s\n' "$1" > "$tmp/p.scad"; openscad -q -o "$parts/$2.stl" "$tmp/p.scad" 2>/dev/null; }
  for n in 24 40 64 96 140 200 260 330; do        # spheres: about n*n/2 .. n*n triangles
    scad "sphere(r = 15, \$fn = $n);" "sphere_$n"
  done
  for n in 32 64 128 256 512 1024; do              # cylinders with a bore
    scad "difference() { cylinder(h = 20, r = 12, \$fn = $n); translate([0, 0, -1]) cylinder(h = 22, r = 5, \$fn = $n); }" "tube_$n"
  done
  for s in 10 20 40 60 90 120 160 200 240 300; do  # twisted lobed extrusions (bench_model.scad)
    scad "linear_extrude(height = 40, twist = 60, slices = $s) polygon([for (i = [0:199]) let(a = 360 * i / 200, r = 15.6 + 2.2 * sin(7 * a)) [r * cos(a), r * sin(a)]]);" "twist_$s"
  done
  for n in 16 32 48 64 96 128 160 200 240 350; do  # tori
    scad "rotate_extrude(\$fn = $n) translate([20, 0]) circle(r = 6, \$fn = $n);" "torus_$n"
  done
fi
if [ "${FORMAT:-ascii}" = binary ]; then
  mkdir -p "$tmp/binary"
  for f in "$parts"/*.stl; do admesh -c -b "$tmp/binary/$(basename "$f")" "$f" >/dev/null; done
  parts=$tmp/binary
fi
count=$(ls "$parts"/*.stl | wc -l)
tris=$("$cli" check "$parts" 2>/dev/null | awk -F'|' 'NR > 4 { s += $6 } END { print s }')

# Each command run RUNS times (default 3), the three commands alternating so that they share
# the machine's load; per command the median wall time in seconds and the CPU seconds
# (user + sys, all threads) of that median run.
runs=${RUNS:-3}
timed() {  # timed NAME CMD...: one run, appends "wall cpu" to $tmp/NAME
  name=$1
  shift
  /usr/bin/time -f '%e %U %S' -o "$tmp/t" "$@" >/dev/null 2>&1 || true
  tail -n 1 "$tmp/t" | awk '{ printf "%.3f %.3f\n", $1, $2 + $3 }' >> "$tmp/$name"
}
median() { sort -n "$tmp/$1" | sed -n "$(( (runs + 1) / 2 ))p"; }
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
i=0
while [ "$i" -lt "$runs" ]; do
  timed ours "$cli" check "$parts" --summary "$tmp/s.md" --junit "$tmp/j.xml"
  timed ad sh -c 'for f in "$1"/*.stl; do admesh "$f" >/dev/null 2>&1; done' sh "$parts"
  timed nosi "$cli" check "$parts" --summary "$tmp/s.md" --no-self-intersections
  [ -n "${BASE:-}" ] && timed base "$BASE/src/printtwin" check "$parts" --summary "$tmp/s.md" --junit "$tmp/j.xml"
  i=$((i + 1))
done
set -- $(median ours)
ours_wall=$1 ours_cpu=$2
set -- $(median nosi)
nosi_wall=$1 nosi_cpu=$2
set -- $(median ad)
ad_wall=$1 ad_cpu=$2

printf '%d files, %s triangles in all; %s cores; load average %s before, %s after\n' \
  "$count" "$tris" "$(nproc)" "$load_before" "$(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-52s %8s s wall %8s s CPU\n' "printtwin check DIR --summary --junit" "$ours_wall" "$ours_cpu"
printf '%-52s %8s s wall %8s s CPU\n' "printtwin check DIR --no-self-intersections" "$nosi_wall" "$nosi_cpu"
printf '%-52s %8s s wall %8s s CPU\n' "admesh FILE, each file in turn" "$ad_wall" "$ad_cpu"
if [ -n "${BASE:-}" ]; then
  set -- $(median base)
  printf '%-52s %8s s wall %8s s CPU\n' "BASE: printtwin check DIR --summary --junit" "$1" "$2"
fi
awk -v a="$ours_wall" -v b="$ad_wall" -v c="$ours_cpu" -v d="$ad_cpu" \
  'BEGIN { printf "ratio printtwin / admesh: %.2f wall, %.2f CPU\n", a / b, c / d }'
