#!/usr/bin/env bash
# Regenerates bench/RESULTS.md: every special path (SIMD kernel, memory trick, helper
# thread) timed against its plain twin on this machine, side by side, and the 10 % rule
# applied (a path stays only when it saves at least 10 % of its stage's time).
#
# The twins are switched at run time in one binary with PRINTTWIN_PLAIN=<name>
# (src/core/plain_path.hpp); a name the binary does not know measures no difference. The
# compiler flag -march=x86-64-v2 cannot be switched at run time: its rows compare this build
# with a build configured with -DPRINTTWIN_X86_64_V2=OFF, given as MARCH_BASE_BUILD (the
# rows are skipped without it).
#
# Per stage and run, the stage is timed once with every special path on and once with each
# path's twin, in an order rotated from run to run; the table gives the medians over RUNS.
# Timings on a shared machine are noisy: the machine's load is recorded with the results.
#
# Usage: bench/results.sh [build-dir]   env: RUNS (default 3), MARCH_BASE_BUILD, OUT
#   (default bench/RESULTS.md). Needs the bench programs and printtwin built in build-dir
#   and the benchmark part (bench/make_bench_data.sh, run first by this script).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
runs="${RUNS:-3}"
out="${OUT:-$root/bench/RESULTS.md}"
# shellcheck source=bench/timing_lib.sh
. "$root/bench/timing_lib.sh"

# The special paths: name | stage (see timing_lib.sh; "build:" = the -march rows) |
# verdict basis (cpu: user + system of all threads, robust under load; wall: for a path
# that trades CPU for elapsed time) | what it is. Edit this list only.
PATHS='
face_avx2         | bench:deviation_bench:BM_DeviationStage/ | cpu  | AVX2 4-wide face-square distance test (deviation/deposit_surface.cpp)
mesh_query_avx2   | bench:deviation_bench:BM_DeviationStage/ | cpu  | AVX2 candidate box filter + 4-wide exact closest point (mesh/mesh_query_embree.cpp)
distance_prefetch | bench:deviation_bench:BM_DeviationStage/ | cpu  | software prefetch of scattered query points (deviation/deposit_surface.cpp, mesh_distance.cpp)
nibbles_pdep      | bench:deposit_bench:BM_DepositOnly/      | cpu  | BMI2 PDEP tag-nibble writes (deposit/voxel_grid.cpp)
chunk_prefault    | bench:deposit_bench:BM_DepositOnly/      | cpu  | madvise(MADV_POPULATE_WRITE) per fresh grid chunk (deposit/voxel_grid.cpp)
bead_avx512       | bench:deposit_bench:BM_DepositOnly/      | cpu  | AVX-512 bead tile kernel (deposit/bead_raster.cpp)
bead_avx2         | bench:deposit_bench:BM_DepositOnly/      | cpu  | AVX2 bead tile kernel (deposit/bead_raster.cpp)
writer_thread     | bench:deposit_bench:BM_DepositOnly/      | wall | grid writer helper thread (deposit/grid_writer.cpp)
claim_pages       | bench:deposit_bench:BM_DepositOnly/      | cpu  | ZeroedArray::claim page reuse (deposit/deposit.cpp)
default_init      | bench:bgcode_bench:BM_DecodeBinary/1    | cpu  | default-initialised byte buffers, no zero fill (gcode/heatshrink.hpp)
sha_ni            | cli:verify:load                          | wall | SHA extensions for the input hashes (core/io.cpp); stage: verify "load"
tune_allocator    | cli:verify                               | cpu  | mallopt tuning of glibc malloc (core/io.cpp tune_allocator_for_jobs)
march_x86_64_v2   | build:bench:deviation_bench:BM_DeviationStage/ | cpu | -march=x86-64-v2 for all code (CMakeLists.txt PRINTTWIN_X86_64_V2)
march_x86_64_v2   | build:bench:deposit_bench:BM_DepositOnly/      | cpu | -march=x86-64-v2 for all code (CMakeLists.txt PRINTTWIN_X86_64_V2)
march_x86_64_v2   | build:cli:verify                               | cpu | -march=x86-64-v2 for all code (CMakeLists.txt PRINTTWIN_X86_64_V2)
'

"$root/bench/make_bench_data.sh" "$build" > /dev/null
[ -n "${MARCH_BASE_BUILD:-}" ] && [ ! -d "$MARCH_BASE_BUILD/benchdata" ] && ln -s "$build/benchdata" "$MARCH_BASE_BUILD/benchdata"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
field() { echo "$1" | cut -d'|' -f"$2" | sed 's/^ *//; s/ *$//'; }
rows=()
while IFS= read -r line; do [ -n "${line// }" ] && rows+=("$line"); done <<< "$PATHS"

# The configurations of a stage: "special" then one per row (its index); timed per run.
stages=()
for line in "${rows[@]}"; do
  s=$(field "$line" 2)
  [[ " ${stages[*]-} " == *" $s "* ]] || stages+=("$s")
done
started=$(date -u '+%Y-%m-%d %H:%M UTC')
machine_before=$(machine_line)
for stage in "${stages[@]}"; do
  configs=(special)
  for i in "${!rows[@]}"; do [ "$(field "${rows[$i]}" 2)" = "$stage" ] && configs+=("$i"); done
  if [[ "$stage" == build:* ]] && [ -z "${MARCH_BASE_BUILD:-}" ]; then continue; fi
  for ((r = 0; r < runs; ++r)); do
    n=${#configs[@]}
    for ((k = 0; k < n; ++k)); do
      plain=""
      c=${configs[$(( (k + r) % n ))]}
      if [[ "$stage" == build:* ]]; then
        b="$build"; [ "$c" = special ] || b="$MARCH_BASE_BUILD"
        DATA_BUILD="$build" time_stage "$b" "${stage#build:}" "" >> "$tmp/$c.${stage//[^A-Za-z0-9]/_}"
      else
        [ "$c" = special ] || plain=$(field "${rows[$c]}" 1)
        time_stage "$build" "$stage" "$plain" >> "$tmp/$c.${stage//[^A-Za-z0-9]/_}"
      fi
      echo "  $stage run $((r + 1))/$runs ${plain:-special}: $(tail -1 "$tmp/$c.${stage//[^A-Za-z0-9]/_}")" >&2
    done
  done
done

{
  echo "# Special paths against their plain twins"
  echo
  echo "Generated by \`bench/results.sh\` (do not edit by hand). Measured $started on:"
  echo "$machine_before (at the start; at the end: load average $(cut -d' ' -f1-3 /proc/loadavg))."
  echo
  echo "Each stage was timed $runs times per configuration, alternating (every special path on, then"
  echo "each path's plain twin via \`PRINTTWIN_PLAIN=<name>\`, the order rotated per run); medians in ms."
  echo "CPU = user + system time of every thread of the stage; wall = elapsed. The machine is shared"
  echo "(2 cores, other jobs running): wall times are noisy, so most verdicts use CPU time. A path is"
  echo "kept when its twin takes at least 10 % more of the stage's time (saving = (plain - special) / plain)."
  echo "Benchmark part: bench/make_bench_data.sh (201k triangles, PrusaSlicer G-code at 0.2 mm)."
  echo
  echo "| path | what | stage | special wall / CPU | plain wall / CPU | saving (basis) | verdict |"
  echo "|---|---|---|---:|---:|---:|---|"
  for i in "${!rows[@]}"; do
    line=${rows[$i]}
    name=$(field "$line" 1) stage=$(field "$line" 2) basis=$(field "$line" 3) what=$(field "$line" 4)
    key=${stage//[^A-Za-z0-9]/_}
    if [ ! -s "$tmp/$i.$key" ]; then
      echo "| \`$name\` | $what | \`$stage\` | | | not measured | (set MARCH_BASE_BUILD) |"
      continue
    fi
    col=2; [ "$basis" = wall ] && col=1
    sw=$(awk '{print $1}' "$tmp/special.$key" | median) sc=$(awk '{print $2}' "$tmp/special.$key" | median)
    pw=$(awk '{print $1}' "$tmp/$i.$key" | median) pc=$(awk '{print $2}' "$tmp/$i.$key" | median)
    s=$(awk -v c=$col '{print $c}' "$tmp/special.$key" | median) p=$(awk -v c=$col '{print $c}' "$tmp/$i.$key" | median)
    saving=$(awk -v s="$s" -v p="$p" 'BEGIN {printf "%.1f", p > 0 ? 100 * (p - s) / p : 0}')
    verdict=$(awk -v x="$saving" 'BEGIN {print (x >= 10) ? "keep" : "drop"}')
    printf '| `%s` | %s | `%s` | %.0f / %.0f | %.0f / %.0f | %s %% (%s) | %s |\n' \
      "$name" "$what" "$stage" "$sw" "$sc" "$pw" "$pc" "$saving" "$basis" "$verdict"
  done
} > "$out"
echo "wrote $out" >&2
