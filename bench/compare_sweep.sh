#!/usr/bin/env bash
# A 4-variant layer-height sweep of a 20 mm-cube-sized part, three ways, whole process
# against whole process (wall time, median of RUNS):
#   sweep     one `printtwin compare --vary layer_height=0.1,0.15,0.2,0.3`
#   verify    4 x `printtwin verify part --set layer_height=h` (verify slices the part
#             itself): what a user runs without compare
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

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }

# Runs a command under /usr/bin/time, appending "wall cpu" (cpu = user + sys) to $acc.
timed() { /usr/bin/time -f "%e %U %S" -a -o "$acc" "$@"; }
# Sums the wall and CPU seconds of the commands run by "$@" (a shell function).
measure() {
  acc="$tmp/acc.$RANDOM"; : > "$acc"
  "$@"
  awk '{w += $1; c += $2 + $3} END {printf "%.3f %.3f\n", w, c}' "$acc"
}

run_sweep() {
  timed "$cli" compare "$part" --vary "layer_height=$(IFS=,; echo "${heights[*]}")" --voxel "$voxel" \
    --variant-reports "$reports" -o "$tmp/sweep" > "$tmp/sweep.out"
}
run_singles() {
  local h
  for h in "${heights[@]}"; do
    timed "$cli" compare "$part" --vary "layer_height=$h" --voxel "$voxel" --variant-reports "$reports" \
      -o "$tmp/single-$h" > /dev/null
  done
}
have_verify=0
if "$cli" verify --help > /dev/null 2>&1; then have_verify=1; fi
run_verifies() {
  local h
  for h in "${heights[@]}"; do
    # verify slices the part itself; exit 1 = the part failed its gates: still a full run
    timed "$cli" verify "$part" --set "layer_height=$h" --voxel "$voxel" --out "$tmp/verify-$h" \
      > /dev/null || true
  done
}

sweep=(); singles=(); verifies=()
for ((r = 0; r < runs; ++r)); do
  sweep+=("$(measure run_sweep)")
  singles+=("$(measure run_singles)")
  if [ "$have_verify" = 1 ]; then verifies+=("$(measure run_verifies)"); fi
done
col() { printf '%s\n' "${@:2}" | awk -v c="$1" '{print $c}' | median; }
sw=$(col 1 "${sweep[@]}"); sc=$(col 2 "${sweep[@]}")
echo "part: $part, voxel $voxel mm, variant reports: $reports, median of $runs"
cat "$tmp/sweep.out"
printf '%-44s %9s %9s\n' "" "wall s" "CPU s"
printf '%-44s %9.2f %9.2f\n' "compare sweep (4 variants, one process)" "$sw" "$sc"
gw=$(col 1 "${singles[@]}"); gc=$(col 2 "${singles[@]}")
printf '%-44s %9.2f %9.2f   sweep/this: wall %.2f, CPU %.2f\n' "4 one-variant compare processes" "$gw" "$gc" \
  "$(echo "$sw / $gw" | bc -l)" "$(echo "$sc / $gc" | bc -l)"
if [ "$have_verify" = 1 ]; then
  vw=$(col 1 "${verifies[@]}"); vc=$(col 2 "${verifies[@]}")
  printf '%-44s %9.2f %9.2f   sweep/this: wall %.2f, CPU %.2f\n' "4 verify processes (--set layer_height=h)" "$vw" "$vc" \
    "$(echo "$sw / $vw" | bc -l)" "$(echo "$sc / $vc" | bc -l)"
else
  echo "(this build has no verify subcommand: verify runs not measured)"
fi
