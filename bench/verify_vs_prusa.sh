#!/usr/bin/env bash
# Whole `printtwin verify` of the benchmark part from PrusaSlicer's G-code, side by side with
# PrusaSlicer slicing the same part (issue 5's goal: verify in under a third of PrusaSlicer's
# time). Both whole processes, same session, alternating, median of RUNS; CPU = user + sys.
# Also prints verify's stage timings (report.json "timings_s") of the last run.
# Usage: bench/verify_vs_prusa.sh [build-dir]   env: RUNS (default 3); BASE=<build-dir or
# printtwin binary> also times that verify in the same rounds (before / after a change);
# VERIFY_ARGS: more options for both verify runs (e.g. VERIFY_ARGS=--no-conserve-volume).
# Needs openscad and prusa-slicer (bench/make_bench_data.sh builds the inputs once).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
runs="${RUNS:-3}"
read -r -a extra <<< "${VERIFY_ARGS:-}"
"$root/bench/make_bench_data.sh" "$build"
data="$build/benchdata"
ini="$root/../shared/peers/prusa_ender3.ini"
[ -f "$ini" ] || ini=/work/shared/peers/prusa_ender3.ini
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

timed() {  # appends "wall cpu maxrss_kb" of "$@" to $out
  /usr/bin/time -f "%e %U %S %M" -o "$tmp/t" "$@" > /dev/null 2>&1 || true
  # time writes "Command exited with non-zero status N" first when the gate fails
  awk '/^[0-9]/ {printf "%.3f %.3f %d\n", $1, $2 + $3, $4}' "$tmp/t" >> "$out"
}
out="$tmp/prusa"; : > "$out"; prusa="$out"
out="$tmp/verify"; : > "$out"; ver="$out"
out="$tmp/base"; : > "$out"; basef="$out"
base="${BASE:-}"
[ -z "$base" ] || [ -f "$base" ] || base="$base/src/printtwin"
for ((r = 0; r < runs; ++r)); do
  out="$prusa" timed prusa-slicer --load "$ini" --layer-height 0.2 --center 110,110 \
    --export-gcode -o "$tmp/p.gcode" "$data/bench_model.stl"
  out="$ver" timed "$build/src/printtwin" verify "$data/bench_model.stl" \
    --gcode "$data/bench_model.gcode" --out "$tmp/report" --quiet "${extra[@]}"
  [ -z "$base" ] || out="$basef" timed "$base" verify "$data/bench_model.stl" \
    --gcode "$data/bench_model.gcode" --out "$tmp/base_report" --quiet "${extra[@]}"
done
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
col() { awk -v c="$2" '{print $c}' "$1" | median; }
pw=$(col "$prusa" 1); pc=$(col "$prusa" 2); vw=$(col "$ver" 1); vc=$(col "$ver" 2)
echo "bench part: $(grep -c 'facet normal' "$data/bench_model.stl") triangles," \
  "$(wc -l < "$data/bench_model.gcode") G-code lines; median of $runs"
printf '%-40s %8s %8s %10s\n' "" "wall s" "CPU s" "peak MB"
printf '%-40s %8.2f %8.2f %10.0f\n' "prusa-slicer --export-gcode" "$pw" "$pc" "$(echo "$(col "$prusa" 3) / 1024" | bc -l)"
printf '%-40s %8.2f %8.2f %10.0f\n' "printtwin verify (whole, with report)" "$vw" "$vc" \
  "$(echo "$(col "$ver" 3) / 1024" | bc -l)"
printf 'verify / PrusaSlicer: wall %.2f, CPU %.2f (goal < 0.33)\n' \
  "$(echo "$vw / $pw" | bc -l)" "$(echo "$vc / $pc" | bc -l)"
if [ -n "$base" ]; then
  bw=$(col "$basef" 1); bc_=$(col "$basef" 2)
  printf '%-40s %8.2f %8.2f %10.0f\n' "base verify ($base)" "$bw" "$bc_" \
    "$(echo "$(col "$basef" 3) / 1024" | bc -l)"
  printf 'base / PrusaSlicer: wall %.2f, CPU %.2f\n' "$(echo "$bw / $pw" | bc -l)" \
    "$(echo "$bc_ / $pc" | bc -l)"
fi
python3 - "$tmp/report/report.json" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["timings_s"]
print("verify stages (wall s, last run): " + ", ".join(f"{k} {v:.2f}" for k, v in t.items()))
PY
