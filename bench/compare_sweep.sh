#!/usr/bin/env bash
# A 4-variant layer-height sweep of a 20 mm-cube-sized part, three ways, whole process
# against whole process (wall time, median of RUNS):
#   sweep     one `printtwin compare --vary layer_height=0.1,0.15,0.2,0.3`
#   verify    4 x (`printtwin slice part --layer-height h` + `printtwin verify part --gcode`),
#             what a user runs without compare (when the verify subcommand exists)
#   single    4 separate one-variant `printtwin compare` runs (the same pipeline without the
#             sharing across variants)
# Usage: bench/compare_sweep.sh [build-dir] [part.stl]
#   env: RUNS (default 3), VOXEL (default 0.05), REPORTS (full|none, default full)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
part="${2:-$here/samples/models/curved_part.stl}"
runs="${RUNS:-3}"
voxel="${VOXEL:-0.05}"
reports="${REPORTS:-full}"
cli="$build/src/printtwin"
[ -x "$cli" ] || { echo "no CLI at $cli (build target printtwin_cli)" >&2; exit 2; }
heights=(0.1 0.15 0.2 0.3)
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
export CI=true  # no progress output

now() { date +%s.%N; }
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }

time_sweep() {
  local t0 t1
  t0=$(now)
  "$cli" compare "$part" --vary "layer_height=$(IFS=,; echo "${heights[*]}")" --voxel "$voxel" \
    --variant-reports "$reports" -o "$tmp/sweep" > "$tmp/sweep.out"
  t1=$(now)
  echo "$t1 - $t0" | bc -l
}

time_singles() {
  local t0 t1 h
  t0=$(now)
  for h in "${heights[@]}"; do
    "$cli" compare "$part" --vary "layer_height=$h" --voxel "$voxel" --variant-reports "$reports" \
      -o "$tmp/single-$h" > /dev/null
  done
  t1=$(now)
  echo "$t1 - $t0" | bc -l
}

have_verify=0
if "$cli" verify --help > /dev/null 2>&1; then have_verify=1; fi

time_verifies() {
  local t0 t1 h
  t0=$(now)
  for h in "${heights[@]}"; do
    "$cli" slice "$part" --layer-height "$h" -o "$tmp/verify-$h.gcode" > /dev/null
    "$cli" verify "$part" --gcode "$tmp/verify-$h.gcode" --voxel "$voxel" --out "$tmp/verify-$h" \
      > /dev/null || [ $? -eq 1 ]  # exit 1 = the part failed its gates: still a full run
  done
  t1=$(now)
  echo "$t1 - $t0" | bc -l
}

sweep=(); singles=(); verifies=()
for ((r = 0; r < runs; ++r)); do
  sweep+=("$(time_sweep)")
  singles+=("$(time_singles)")
  if [ "$have_verify" = 1 ]; then verifies+=("$(time_verifies)"); fi
done
ms=$(printf '%s\n' "${sweep[@]}" | median)
mg=$(printf '%s\n' "${singles[@]}" | median)
echo "part: $part, voxel $voxel mm, variant reports: $reports, median of $runs"
cat "$tmp/sweep.out"
printf 'compare sweep (4 variants, one process):     %8.2f s\n' "$ms"
printf '4 one-variant compare processes:             %8.2f s   (sweep = %.2fx of it)\n' "$mg" \
  "$(echo "$ms / $mg" | bc -l)"
if [ "$have_verify" = 1 ]; then
  mv=$(printf '%s\n' "${verifies[@]}" | median)
  printf '4 x (slice + verify) processes:              %8.2f s   (sweep = %.2fx of it)\n' "$mv" \
    "$(echo "$ms / $mv" | bc -l)"
else
  echo "(this build has no verify subcommand: verify runs not measured)"
fi
