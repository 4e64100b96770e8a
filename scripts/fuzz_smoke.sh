#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) in build-fuzz and runs each for a fixed
# time on its seed corpus. Usage: scripts/fuzz_smoke.sh [seconds per target, default 30]
# Exit 0 when no target found a crash, leak or timeout; the findings are left in
# build-fuzz/findings/<target>/ (crash-*, leak-*, timeout-*).
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET=${1:-30}
BUILD=${PRINTTWIN_FUZZ_BUILD_DIR:-build-fuzz}
# PRINTTWIN_FUZZ_PREBUILT=1: the targets are already built in $BUILD (scripts/ci_sanitize.sh
# builds them together with the sanitizer test suite); skip the configure and build.
if [ "${PRINTTWIN_FUZZ_PREBUILT:-0}" != 1 ]; then
  command -v clang++ >/dev/null || { echo "fuzz_smoke: clang++ is needed (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  CC=clang CXX=clang++ cmake -S . -B "$BUILD" -DPRINTTWIN_BUILD_FUZZ=ON -DPRINTTWIN_BUILD_TESTS=OFF \
    -DPRINTTWIN_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo "${launcher[@]}" >/dev/null
  cmake --build "$BUILD" -j"${PRINTTWIN_JOBS:-2}" --target printtwin_fuzz_targets >"$BUILD/build.log" 2>&1 ||
    { tail -40 "$BUILD/build.log"; echo "fuzz_smoke: build failed (full log: $BUILD/build.log)" >&2; exit 1; }
fi
# assimp is not built with the sanitizers: its own leaks on some malformed files (the
# importers' error paths) are suppressed by name here, ours are not.
export LSAN_OPTIONS="suppressions=$PWD/fuzz/lsan_suppressions.txt:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
status=0
# Every target fuzz/<name>_fuzz.cpp, with its seed corpus fuzz/corpus_<name>.
for source in fuzz/*_fuzz.cpp; do
  target=$(basename "$source" _fuzz.cpp)
  corpus=fuzz/corpus_$target
  [ -d "$corpus" ] || { echo "fuzz_smoke: $corpus (seed corpus of $source) is missing" >&2; exit 1; }
  work="$BUILD/corpus/$target"
  findings="$BUILD/findings/$target"
  mkdir -p "$work" "$findings"
  log="$BUILD/findings/$target.log"
  if "$BUILD/fuzz/${target}_fuzz" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=2048 \
       -max_len=8192 -artifact_prefix="$findings/" -print_final_stats=1 "$work" "$corpus" >"$log" 2>&1; then
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    echo "fuzz $target: ${SECONDS_PER_TARGET} s, $runs executions, no findings"
  else
    echo "fuzz $target: FINDING (see $log and $findings/)" >&2
    status=1
  fi
done
exit $status
