#!/usr/bin/env bash
# Sanitizer job: the whole test suite built with AddressSanitizer + UBSan (gcc, build-asan),
# then a smoke run of every libFuzzer target (clang, build-fuzz; scripts/fuzz_smoke.sh).
# Usage: scripts/ci_sanitize.sh [fuzz seconds per target, default 30]
# Not part of .ci/run yet: a clean build under the sanitizers has not been timed against
# CI's 90-minute limit on 2 cores (see docs/robustness.md).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${PRINTTWIN_ASAN_BUILD_DIR:-build-asan}
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
start=$(date +%s)
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPRINTTWIN_BUILD_BENCH=OFF "${launcher[@]}" \
  -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
cmake --build "$BUILD" -j"$(nproc)" --target printtwin_tests printtwin_cli >"$BUILD/build.log" 2>&1 ||
  { tail -40 "$BUILD/build.log"; exit 1; }
echo "ci_sanitize: build $(( $(date +%s) - start )) s"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/fuzz/lsan_suppressions.txt:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest --test-dir "$BUILD" --output-on-failure --parallel "$(nproc)" --timeout 1800
echo "ci_sanitize: build + suite $(( $(date +%s) - start )) s"
scripts/fuzz_smoke.sh "${1:-30}"
echo "ci_sanitize: total $(( $(date +%s) - start )) s"
