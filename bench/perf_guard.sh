#!/usr/bin/env bash
# Performance guard: builds two commits and times the benchmark stages side by side,
# alternating, on the benchmark part; exits 1 when HEAD is more than 10 % slower than BASE
# in any stage. Run it before merging a change that may touch speed. Not in CI: timings on a
# shared machine are noisy, so it alternates the two builds, repeats (RUNS) and compares
# medians, by default of CPU time (user + system of all threads), which load disturbs far
# less than elapsed time.
#
# Usage: bench/perf_guard.sh BASE HEAD     (commits, branches or tags of this repository)
#   env: RUNS (default 5), BASIS (cpu | wall, default cpu), LIMIT (default 10, per cent),
#        STAGES (override the stage list below; see bench/timing_lib.sh for the syntax),
#        KEEP=1 (keep the temporary worktrees and builds; printed at the end)
# Each commit is checked out with `git worktree add --detach` into a temporary directory and
# built in Release with ccache (unchanged files are cache hits), benchmark programs and CLI
# only. The inputs come from bench/make_bench_data.sh (needs prusa-slicer), built once.
# A stage a commit does not have (renamed benchmark) is reported and not judged.
set -euo pipefail
[ $# -eq 2 ] || { sed -n '2,17p' "$0"; exit 2; }
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(git -C "$here" rev-parse --show-toplevel)"
runs="${RUNS:-5}" basis="${BASIS:-cpu}" limit="${LIMIT:-10}"
# shellcheck source=bench/timing_lib.sh
. "$here/timing_lib.sh"
STAGES="${STAGES:-bench:simulate_bench:BM_Simulate/marlin2 bench:deposit_bench:BM_DepositOnly/ bench:deviation_bench:BM_DeviationStage/ bench:slice_bench:BM_SliceSphere200k bench:check_bench:BM_CheckWhole cli:verify}"

tmp="$(mktemp -d "${TMPDIR:-/tmp}/perf_guard.XXXXXX")"
cleanup() {
  if [ "${KEEP:-0}" = 1 ]; then echo "kept $tmp" >&2; return; fi
  for side in base head; do git -C "$repo" worktree remove --force "$tmp/$side" 2> /dev/null || true; done
  rm -rf "$tmp"
}
trap cleanup EXIT

targets=(printtwin_cli)
for s in $STAGES; do [[ "$s" == bench:* ]] && { p=${s#bench:}; targets+=("${p%%:*}"); }; done
launcher=()
command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# Paths under the temporary directory hash as relative ones: the two checkouts (and any
# other checkout built the same way) share the cache.
export CCACHE_BASEDIR="$tmp"
for side in base head; do
  rev=$1; [ "$side" = head ] && rev=$2
  git -C "$repo" worktree add --detach "$tmp/$side" "$rev" > /dev/null 2>&1
  echo "building $side ($rev = $(git -C "$repo" rev-parse --short "$rev"))" >&2
  cmake -S "$tmp/$side" -B "$tmp/$side/build" -DCMAKE_BUILD_TYPE=Release -DPRINTTWIN_WERROR=ON -DPRINTTWIN_BUILD_TESTS=OFF \
    "${launcher[@]}" > "$tmp/$side.log" 2>&1
  cmake --build "$tmp/$side/build" -j"$(nproc)" --target "${targets[@]}" >> "$tmp/$side.log" 2>&1 ||
    { tail -30 "$tmp/$side.log" >&2; echo "perf_guard: $side does not build" >&2; exit 2; }
done
"$here/make_bench_data.sh" "$tmp/base/build" > /dev/null
export DATA_BUILD="$tmp/base/build"

col=2; [ "$basis" = wall ] && col=1
echo "$(machine_line)" >&2
for ((r = 0; r < runs; ++r)); do
  for s in $STAGES; do
    key=${s//[^A-Za-z0-9]/_}
    order=(base head); ((r % 2)) && order=(head base)  # ABBA: drift cancels
    for side in "${order[@]}"; do
      time_stage "$tmp/$side/build" "$s" "" >> "$tmp/$side.$key"
      echo "  run $((r + 1))/$runs $side $s: $(tail -1 "$tmp/$side.$key")" >&2
    done
  done
done

status=0
printf '%-50s %12s %12s %8s\n' "stage (median $basis ms of $runs)" base head change
for s in $STAGES; do
  key=${s//[^A-Za-z0-9]/_}
  b=$(awk -v c=$col '{print $c}' "$tmp/base.$key" | median)
  h=$(awk -v c=$col '{print $c}' "$tmp/head.$key" | median)
  if [ "$b" = nan ] || [ "$h" = nan ]; then
    printf '%-50s %12s %12s %8s\n' "$s" "$b" "$h" "n/a"
    continue
  fi
  change=$(awk -v b="$b" -v h="$h" 'BEGIN {printf "%+.1f", 100 * (h - b) / b}')
  verdict=""
  if awk -v x="$change" -v l="$limit" 'BEGIN {exit !(x > l)}'; then verdict="  SLOWER"; status=1; fi
  printf '%-50s %12.1f %12.1f %7s%%%s\n' "$s" "$b" "$h" "$change" "$verdict"
done
[ $status -eq 0 ] && echo "perf_guard: no stage slower by more than $limit %" || echo "perf_guard: slowdown over $limit %"
exit $status
