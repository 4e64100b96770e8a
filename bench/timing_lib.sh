# Shared by bench/results.sh and bench/perf_guard.sh (sourced, not run): one timing of a
# benchmark stage in a given build, on the benchmark part (bench/make_bench_data.sh).
#
# A stage is "bench:<program>:<filter>" (a Google Benchmark of bench/: the median over the
# repetitions it runs of its real time and of its CPU time, process-wide for the stages
# that declare MeasureProcessCPUTime), "cli:verify" (the whole `printtwin verify` of the
# benchmark part from PrusaSlicer's G-code: the process's wall and user + system time),
# "cli:verify:<stage>" (that stage's wall time in the report's timings_s, both columns) or
# "cli:simulate" (`printtwin simulate` of that G-code with --deposit-summary: simulate and
# deposit alone, the process's wall and user + system time).
# Timings are in ms, printed as "wall cpu".

# The environment a bench program reads its inputs from (bench part for the stages that
# take one; the bgcode bench reads the shared real-world pair by itself).
stage_env() {  # stage_env BUILD PROGRAM -> "VAR=value ..." lines
  local data="$1/benchdata"
  case "$2" in
    deviation_bench) printf '%s\n' "PRINTTWIN_BENCH_GCODE=$data/bench_model.gcode" \
                                    "PRINTTWIN_BENCH_MESH=$data/bench_model.stl" ;;
    deposit_bench | octomap_bench) printf '%s\n' "PRINTTWIN_DEPOSIT_GCODE=$data/bench_model.gcode" ;;
  esac
}

# time_stage BUILD STAGE PLAIN -> prints one timing "wall cpu" (ms) of STAGE in BUILD, the special
# paths named in PLAIN (a PRINTTWIN_PLAIN list; empty: none) taking their plain twins.
# DATA_BUILD (default BUILD) holds benchdata/.
time_stage() {
  local build="$1" stage="$2" plain="$3" data_build="${DATA_BUILD:-$1}"
  local kind="${stage%%:*}" rest="${stage#*:}"
  local -a envs=()
  [ -n "$plain" ] && envs+=("PRINTTWIN_PLAIN=$plain")
  case "$kind" in
    bench)
      local prog="${rest%%:*}" filter="${rest#*:}" line
      while IFS= read -r line; do [ -n "$line" ] && envs+=("$line"); done < <(stage_env "$data_build" "$prog")
      env -u PRINTTWIN_PLAIN "${envs[@]}" "$build/bench/$prog" --benchmark_filter="$filter" \
        --benchmark_format=json 2> /dev/null | python3 -c '
import json, statistics, sys
runs = [b for b in json.load(sys.stdin)["benchmarks"] if b.get("run_type") == "iteration"]
scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}
ok = [b for b in runs if not b.get("error_occurred")]
med = lambda key: statistics.median(b[key] * scale[b.get("time_unit", "ns")] for b in ok)
print("%.3f %.3f" % (med("real_time"), med("cpu_time")) if ok else "nan nan")'
      ;;
    cli)
      local data="$data_build/benchdata" key="${rest#verify}" tmp
      tmp="$(mktemp -d)"
      if [ "$rest" = simulate ]; then
        env -u PRINTTWIN_PLAIN "${envs[@]}" /usr/bin/time -f "%e %U %S" -o "$tmp/t" "$build/src/printtwin" \
          simulate "$data/bench_model.gcode" --deposit-summary -q > /dev/null 2>&1 || true
        awk '{printf "%.1f %.1f\n", 1e3 * $1, 1e3 * ($2 + $3)}' "$tmp/t"
        rm -rf "$tmp"
        return
      fi
      env -u PRINTTWIN_PLAIN "${envs[@]}" /usr/bin/time -f "%e %U %S" -o "$tmp/t" "$build/src/printtwin" verify \
        "$data/bench_model.stl" --gcode "$data/bench_model.gcode" --out "$tmp/report" --quiet > /dev/null 2>&1 || true
      if [ -n "$key" ]; then
        python3 -c 'import json, sys
t = json.load(open(sys.argv[1]))["timings_s"].get(sys.argv[2][1:])
print("nan nan" if t is None else f"{1e3 * t:.1f} {1e3 * t:.1f}")' "$tmp/report/report.json" "$key"
      else
        awk '{printf "%.1f %.1f\n", 1e3 * $1, 1e3 * ($2 + $3)}' "$tmp/t"
      fi
      rm -rf "$tmp"
      ;;
    *) echo "unknown stage kind: $stage" >&2; return 2 ;;
  esac
}

# The median of the numbers on stdin.
median() { sort -g | awk '{a[NR]=$1} END {if (NR == 0) print "nan"; else print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }

# A one-line description of this machine and its load (timings on a shared machine are noisy).
machine_line() {
  local flags
  flags=$(grep -m1 '^flags' /proc/cpuinfo | tr ' ' '\n' | grep -E '^(avx2|avx512f|bmi2|sha_ni)$' | tr '\n' ' ')
  echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(nproc) cores" \
    "(${flags% }), $(uname -sr), $(c++ --version | head -1), load average $(cut -d' ' -f1-3 /proc/loadavg)"
}
