#!/usr/bin/env bash
# A 4-variant PrusaSlicer layer-height sweep of the benchmark part through
#   sweep   one `printtwin compare --slicer prusa-slicer --vary layer_height=...`
# against the same work done one piece after another:
#   parts   4 x `prusa-slicer ... --export-gcode` + 4 x `printtwin verify --gcode`
# Whole processes, wall time, median of RUNS. Issue 25's goal: sweep <= 1.2 x parts.
# Usage: bench/compare_slicer_sweep.sh [build-dir] [part.stl]
#   env: RUNS (default 1), VOXEL (default 0.05), HEIGHTS (default "0.1 0.15 0.2 0.3")
# Needs prusa-slicer; the part defaults to <build>/benchdata/bench_model.stl
# (bench/make_bench_data.sh).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
part="${2:-$build/benchdata/bench_model.stl}"
runs="${RUNS:-1}"
voxel="${VOXEL:-0.05}"
read -r -a heights <<< "${HEIGHTS:-0.1 0.15 0.2 0.3}"
cli="$build/src/printtwin"
ini="$root/samples/configs/ender3_prusaslicer.ini"
[ -x "$cli" ] || { echo "no CLI at $cli (build target printtwin_cli)" >&2; exit 2; }
[ -f "$part" ] || { echo "no part at $part (bench/make_bench_data.sh)" >&2; exit 2; }
command -v prusa-slicer >/dev/null || { echo "prusa-slicer is not installed (apt-get install prusa-slicer)" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
export CI=true

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
now() { date +%s.%N; }

sweep() {
  local vary; vary=$(IFS=,; echo "${heights[*]}")
  "$cli" compare "$part" --slicer prusa-slicer --config "$ini" --vary "layer_height=$vary" \
    --voxel "$voxel" --variant-reports json -o "$tmp/sweep" > /dev/null 2>&1 || true
}
parts() {
  local slice=0 verify=0 t0 t1
  for h in "${heights[@]}"; do
    t0=$(now)
    prusa-slicer --load "$ini" --layer-height "$h" --export-gcode -o "$tmp/p$h.gcode" "$part" > /dev/null 2>&1
    t1=$(now); slice=$(echo "$slice + $t1 - $t0" | bc)
    "$cli" verify "$part" --gcode "$tmp/p$h.gcode" --voxel "$voxel" --out "$tmp/v$h" -q > /dev/null 2>&1 || true
    t0=$(now); verify=$(echo "$verify + $t0 - $t1" | bc)
  done
  echo "$slice $verify" > "$tmp/split"
}

: > "$tmp/sweep.t"; : > "$tmp/parts.t"
for _ in $(seq "$runs"); do
  t0=$(now); sweep; t1=$(now); echo "$t1 - $t0" | bc >> "$tmp/sweep.t"
  t0=$(now); parts; t1=$(now); echo "$t1 - $t0" | bc >> "$tmp/parts.t"
done
s=$(median < "$tmp/sweep.t"); p=$(median < "$tmp/parts.t")
read -r ps pv < "$tmp/split"
echo "part $(basename "$part"), ${#heights[@]} variants (layer_height ${heights[*]}), voxel $voxel, $runs run(s), $(nproc) cores"
printf "sweep  printtwin compare --slicer prusa-slicer    %8.1f s\n" "$s"
printf "parts  4 x prusa-slicer + 4 x verify --gcode    %8.1f s  (slicing %.1f s, verify %.1f s, last run)\n" "$p" "$ps" "$pv"
printf "ratio  sweep / parts                            %8.2f   (goal <= 1.20)\n" "$(echo "$s / $p" | bc -l)"
