#!/bin/sh
# Side by side: `printtwin check` against admesh and `prusa-slicer --info` on the same
# closed ~200k-triangle mesh (the bumpy torus of bench/check_bench.cpp). Whole processes,
# median of 3 wall-clock runs each, measured in the same run; prints the ratios.
#   bench/check_vs_peers.sh [build-dir]        (default: build)
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
cli="$build/src/printtwin"
bench="$build/bench/check_bench"
for tool in admesh prusa-slicer; do
  command -v "$tool" >/dev/null || { echo "check_vs_peers: $tool is not installed" >&2; exit 2; }
done
[ -x "$cli" ] && [ -x "$bench" ] || { echo "check_vs_peers: build printtwin_cli and check_bench in $build first" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mesh="$tmp/torus_200k.stl"
"$bench" --write-mesh="$mesh"

# median wall time in seconds of 3 runs of "$@" (output discarded; exit code ignored)
median3() {
  for i in 1 2 3; do
    s=$(date +%s.%N)
    "$@" >/dev/null 2>&1 || true
    e=$(date +%s.%N)
    awk -v s="$s" -v e="$e" 'BEGIN { printf "%.4f\n", e - s }' 
  done | sort -n | sed -n 2p
}

t_ours=$(median3 "$cli" check "$mesh")
t_ours_nosi=$(median3 "$cli" check "$mesh" --no-self-intersections)
t_admesh=$(median3 admesh "$mesh")
t_prusa=$(median3 prusa-slicer --info "$mesh")

printf '%-44s %8.3f s\n' "printtwin check (all checks)" "$t_ours"
printf '%-44s %8.3f s\n' "printtwin check --no-self-intersections" "$t_ours_nosi"
printf '%-44s %8.3f s\n' "admesh (default checks)" "$t_admesh"
printf '%-44s %8.3f s\n' "prusa-slicer --info" "$t_prusa"
printf 'ratio printtwin / admesh        %6.2f\n' "$(awk -v a="$t_ours" -v b="$t_admesh" 'BEGIN { print a / b }')"
printf 'ratio printtwin / prusa --info  %6.2f\n' "$(awk -v a="$t_ours" -v b="$t_prusa" 'BEGIN { print a / b }')"

# CPU seconds (user + sys, median of 3): robust when other jobs share the machine.
if [ -x /usr/bin/time ]; then
  cpu3() {
    for i in 1 2 3; do
      /usr/bin/time -f "%U %S" -o "$tmp/t" "$@" >/dev/null 2>&1 || true
      awk '{ printf "%.3f\n", $1 + $2 }' "$tmp/t"
    done | sort -n | sed -n 2p
  }
  c_ours=$(cpu3 "$cli" check "$mesh")
  c_admesh=$(cpu3 admesh "$mesh")
  c_prusa=$(cpu3 prusa-slicer --info "$mesh")
  printf 'cpu s: printtwin %s, admesh %s, prusa-slicer --info %s; ratios %s / %s\n' \
    "$c_ours" "$c_admesh" "$c_prusa" \
    "$(awk -v a="$c_ours" -v b="$c_admesh" 'BEGIN { printf "%.2f", a / b }')" \
    "$(awk -v a="$c_ours" -v b="$c_prusa" 'BEGIN { printf "%.2f", a / b }')"
fi

# The same facts from each tool, for the record.
"$cli" check "$mesh" | sed -n '2,4p'
admesh "$mesh" | grep -E "Number of facets|Volume|Number of parts|Edges fixed|Backwards" || true
prusa-slicer --info "$mesh" 2>/dev/null | grep -E "number_of_facets|volume|manifold|number_of_parts" || true
