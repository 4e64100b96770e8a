#!/usr/bin/env bash
# Regenerates bench/RESULTS.md: every special path (SIMD kernel, memory trick, helper
# thread) timed against its plain twin on this machine, side by side, and the 10 % rule
# applied (a path stays only when it saves at least 10 % of its stage's time).
#
# The twins are switched at run time in one binary with PRINTTWIN_PLAIN=<name>
# (src/core/plain_path.hpp); a name the binary does not know measures no difference. A
# compiler flag cannot be switched at run time: a "build:" row compares this build with
# another build of the same source configured without the flag, given as MARCH_BASE_BUILD
# (the rows are skipped without it). No such flag is in the build today: -march=x86-64-v2
# measured under 10 % on every stage and was removed.
#
# Per stage and run, the stage is timed once with every special path on and once with each
# path's twin, in an order rotated from run to run; the table gives the medians over RUNS.
# Timings on a shared machine are noisy: the machine's load is recorded with the results.
#
# Usage: bench/results.sh [build-dir]   env: RUNS (default 3), MARCH_BASE_BUILD, OUT
#   (default bench/RESULTS.md), RAW (default OUT with .raw: every timing, one line each
#   "stage|configuration|wall cpu"), FROM_RAW=file (no timing: the table from that file),
#   STAGES=regex (time only the stages matching it, e.g. '^build:'; the other stages'
#   timings are kept from RAW, and the table says when each part was measured).
#   Needs the bench programs and printtwin built in build-dir and the benchmark part
#   (bench/make_bench_data.sh, run first by this script).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
runs="${RUNS:-3}"
out="${OUT:-$root/bench/RESULTS.md}"
raw="${RAW:-${out%.md}.raw}"
# shellcheck source=bench/timing_lib.sh
. "$root/bench/timing_lib.sh"

# The special paths: name | stage (see timing_lib.sh; "build:" = a compiler-flag row) |
# verdict basis (cpu: user + system of all threads, robust under load; wall: for a path
# that trades CPU for elapsed time) | what it is. Edit this list only.
PATHS='
bead_avx512       | bench:deposit_bench:BM_DepositOnly/0     | cpu  | AVX-512 bead tile kernel (deposit/kernels.cpp)
deposit_writer    | cli:simulate                             | wall | grid writes on a writer thread behind the sweep, squeeze on (the sweep reads its own copy of the occupancy; deposit/grid_writer.cpp, deposit/sweep.cpp); stage: simulate with --deposit-summary
sha_ni            | cli:verify:load                          | wall | SHA extensions for the input hashes (core/kernels.cpp); stage: verify "load"
check_fans        | bench:check_bench:BM_SelfIntersectionsWithHealth | cpu | face pairs around certified vertex fans not tested (check/self_intersections_cgal.cpp)
check_star        | bench:check_bench:BM_SelfIntersectionsStar | cpu | no pair tested on a surface certified star-shaped about its vertex mean (check/self_intersections_cgal.cpp)
check_ray_bound   | bench:check_bench:BM_Thickness/           | cpu  | inward rays end past the thinnest sampled wall (check/thickness.cpp)
check_bvh_rays    | bench:check_bench:BM_Thickness/           | cpu  | BVH for rays only, built by Embree at low quality (mesh/mesh_query_embree.cpp, check/thickness.cpp)
check_ray_stream  | bench:check_bench:BM_Thickness/           | cpu  | the rays of 16 faces traced as one Embree stream of coherent rays (mesh/mesh_query_embree.cpp, check/thickness.cpp)
stl_direct        | bench:check_bench:BM_Load/                | cpu  | STL welded straight from its bytes (binary) or the numbers its grammar check read (ASCII, BM_LoadAscii), not through assimp (mesh/mesh_io_assimp.cpp)
bgcode_libdeflate | bench:bgcode_bench:BM_OpenBinary/0        | cpu  | libdeflate, not zlib, inflates and checksums binary G-code blocks (gcode/bgcode.cpp); stage: opening a .bgcode
bgcode_meatpack   | bench:bgcode_bench:BM_DecodeBinary/0      | cpu  | table-driven MeatPack loop, not the byte-at-a-time state machine (gcode/meatpack.cpp); stage: decoding a .bgcode to text
closest_hints     | cli:verify:registration                  | wall | ICP closest-point queries bounded from the triangles of the previous step (mesh/mesh_query_embree.cpp, deviation/registration_search.cpp)
hull_filter       | cli:verify:registration                  | wall | footprint hull drops the points inside the extreme octagon before its sort (deviation/registration.cpp)
octomap_threads   | bench:octomap_bench:BM_OctomapExport/1   | wall | .ot subtrees encoded on all cores, written in order (deposit/octomap_io.cpp); stage: the .ot export
deposit_huge_pages | cli:simulate                            | cpu  | sweep block words in 2 MiB arenas and grid block chunks (6 MiB) marked MADV_HUGEPAGE (deposit/sweep.hpp, deposit/voxel_grid.cpp); stage: simulate with --deposit-summary
huge_pages        | cli:verify                               | wall | blocks of 4 MiB and more from operator new marked MADV_HUGEPAGE (cli/huge_pages.cpp); stage: the whole verify
'

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
field() { echo "$1" | cut -d'|' -f"$2" | sed 's/^ *//; s/ *$//'; }
rows=()
while IFS= read -r line; do [ -n "${line// }" ] && rows+=("$line"); done <<< "$PATHS"

only="${STAGES:-}"
if [ -n "${FROM_RAW:-}" ]; then
  cp "$FROM_RAW" "$tmp/raw"
else
  "$root/bench/make_bench_data.sh" "$build" > /dev/null
  [ -n "${MARCH_BASE_BUILD:-}" ] && [ ! -d "$MARCH_BASE_BUILD/benchdata" ] && ln -s "$build/benchdata" "$MARCH_BASE_BUILD/benchdata"
  # The stages, each with its configurations: "special" and one per row (the row's name).
  stages=()
  for line in "${rows[@]}"; do
    s=$(field "$line" 2)
    [[ " ${stages[*]-} " == *" $s "* ]] || stages+=("$s")
  done
  started=$(date -u '+%Y-%m-%d %H:%M UTC')
  if [ -n "$only" ]; then
    # The other stages' timings and the header of the run that measured them stay.
    [ -f "$raw" ] || { echo "STAGES needs the earlier timings in $raw" >&2; exit 2; }
    awk -F'|' -v re="$only" '/^# partial/ {if (index($0, "stages " re " measured ") == 0) print; next}
      /^#/ {print; next} $1 !~ re' "$raw" > "$tmp/kept"
    cp "$tmp/kept" "$raw"
    partial="# partial stages $only measured $started on $(machine_line)"
  else
    printf '# started %s\n# machine %s\n' "$started" "$(machine_line)" > "$raw"
  fi
  for stage in "${stages[@]}"; do
    if [[ "$stage" == build:* ]] && [ -z "${MARCH_BASE_BUILD:-}" ]; then continue; fi
    if [ -n "$only" ] && ! [[ "$stage" =~ $only ]]; then continue; fi
    configs=(special)
    for line in "${rows[@]}"; do [ "$(field "$line" 2)" = "$stage" ] && configs+=("$(field "$line" 1)"); done
    n=${#configs[@]}
    for ((r = 0; r < runs; ++r)); do
      for ((k = 0; k < n; ++k)); do
        c=${configs[$(( (k + r) % n ))]}
        if [[ "$stage" == build:* ]]; then
          b="$build"; [ "$c" = special ] || b="$MARCH_BASE_BUILD"
          t=$(DATA_BUILD="$build" time_stage "$b" "${stage#build:}" "")
        else
          plain=""; [ "$c" = special ] || plain="$c"
          t=$(time_stage "$build" "$stage" "$plain")
        fi
        echo "$stage|$c|$t" >> "$raw"
        echo "  $stage run $((r + 1))/$runs $c: $t" >&2
      done
    done
  done
  if [ -n "$only" ]; then
    echo "$partial (at the end: load average $(cut -d' ' -f1-3 /proc/loadavg))" >> "$raw"
  else
    echo "# after load average $(cut -d' ' -f1-3 /proc/loadavg)" >> "$raw"
  fi
  cp "$raw" "$tmp/raw"
fi
started=$(sed -n 's/^# started //p' "$tmp/raw") machine_before=$(sed -n 's/^# machine //p' "$tmp/raw")
machine_after=$(sed -n 's/^# after //p' "$tmp/raw")
# The median of column COL (1 wall, 2 cpu) of STAGE's CONFIG timings.
med() { awk -F'|' -v s="$1" -v c="$2" '$1 == s && $2 == c {print $3}' "$tmp/raw" | awk -v k="$3" '{print $k}' | median; }
runs_done=$(awk -F'|' '!/^#/ && $2 == "special" {n[$1]++} END {m = 0; for (s in n) if (n[s] > m) m = n[s]; print m}' "$tmp/raw")

{
  echo "# Special paths against their plain twins"
  echo
  echo "Generated by \`bench/results.sh\` (do not edit by hand). Measured $started on:"
  echo "$machine_before (at the start; at the end: $machine_after)."
  # STAGES runs: what was measured again, when, on what load.
  sed -n 's/^# partial stages \(.*\)$/Stages matching `\1; the others as above./p' "$tmp/raw" |
    sed 's/ measured /` measured again /' 
  echo
  echo "Each stage was timed $runs_done times per configuration, alternating (every special path on, then"
  echo "each path's plain twin via \`PRINTTWIN_PLAIN=<name>\`, the order rotated per run); medians in ms."
  echo "CPU = user + system time of every thread of the stage; wall = elapsed. The machine is shared"
  echo "(2 cores, other jobs running): wall times are noisy, so most verdicts use CPU time. A path is"
  echo "kept when its twin takes at least 10 % more of the stage's time (saving = (plain - special) / plain)."
  echo "Benchmark part: bench/make_bench_data.sh (201k triangles, PrusaSlicer G-code at 0.2 mm)."
  echo "A dropped path is removed from the code afterwards; a name the binary no longer knows then"
  echo "measures no difference (the measurement that dropped it stays in the history of this file)."
  echo
  echo "| path | what | stage | special wall / CPU | plain wall / CPU | saving (basis) | verdict |"
  echo "|---|---|---|---:|---:|---:|---|"
  for i in "${!rows[@]}"; do
    line=${rows[$i]}
    name=$(field "$line" 1) stage=$(field "$line" 2) basis=$(field "$line" 3) what=$(field "$line" 4)
    if [ -z "$(med "$stage" "$name" 1)" ] || [ "$(med "$stage" "$name" 1)" = nan ]; then
      why="(re-run with STAGES matching this stage)"
      [[ "$stage" == build:* ]] && why="(a build row: set MARCH_BASE_BUILD)"
      echo "| \`$name\` | $what | \`$stage\` | | | not measured | $why |"
      continue
    fi
    col=2; [ "$basis" = wall ] && col=1
    sw=$(med "$stage" special 1) sc=$(med "$stage" special 2) pw=$(med "$stage" "$name" 1) pc=$(med "$stage" "$name" 2)
    s=$(med "$stage" special $col) p=$(med "$stage" "$name" $col)
    saving=$(awk -v s="$s" -v p="$p" 'BEGIN {printf "%.1f", (p > 0) ? 100 * (p - s) / p : 0}')
    verdict=$(awk -v x="$saving" 'BEGIN {print (x >= 10) ? "keep" : "drop"}')
    printf '| `%s` | %s | `%s` | %.0f / %.0f | %.0f / %.0f | %s %% (%s) | %s |\n' \
      "$name" "$what" "$stage" "$sw" "$sc" "$pw" "$pc" "$saving" "$basis" "$verdict"
  done
} > "$out"
echo "wrote $out" >&2
