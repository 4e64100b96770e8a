#!/usr/bin/env bash
# Sanitizer job of CI: the whole project built ONCE with clang, AddressSanitizer + UBSan and
# libFuzzer's coverage instrumentation (build-asan), then
#   1. the whole test suite under the sanitizers, and
#   2. a smoke run of every libFuzzer target (fuzz/<name>_fuzz.cpp, linked against the same
#      instrumented library; scripts/fuzz_smoke.sh).
# Usage: scripts/ci_sanitize.sh [fuzz seconds per target, default 30]
# Installs what is missing (clang and libFuzzer's runtime besides setup.sh's packages).
# Optimisation is -O1 with line tables only: the sanitizers need no more to report file and
# line, and it compiles in about half the time of -O2 -g.
set -euo pipefail
cd "$(dirname "$0")/.."
PRINTTWIN_EXTRA_PACKAGES="${PRINTTWIN_EXTRA_PACKAGES:-} clang libclang-rt-14-dev" scripts/setup.sh --packages-only
BUILD=${PRINTTWIN_ASAN_BUILD_DIR:-build-asan}
JOBS=${PRINTTWIN_JOBS:-$(nproc)}
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
sanitize="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fsanitize=fuzzer-no-link"
start=$(date +%s)
CC=clang CXX=clang++ cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=None -DPRINTTWIN_BUILD_BENCH=OFF \
  -DPRINTTWIN_BUILD_FUZZ=ON -DPRINTTWIN_FUZZ_WHOLE_BUILD=ON "${launcher[@]}" \
  -DCMAKE_CXX_FLAGS="-O1 -gline-tables-only -DNDEBUG -fno-omit-frame-pointer $sanitize" \
  -DCMAKE_C_FLAGS="-O1 -gline-tables-only -DNDEBUG -fno-omit-frame-pointer $sanitize" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
cmake --build "$BUILD" -j"$JOBS" --target printtwin_tests printtwin_cli printtwin_fuzz_targets \
  >"$BUILD/build.log" 2>&1 ||
  { tail -40 "$BUILD/build.log"; echo "ci_sanitize: build failed (full log: $BUILD/build.log)" >&2; exit 1; }
echo "ci_sanitize: ASan+UBSan build $(( $(date +%s) - start )) s"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/fuzz/lsan_suppressions.txt:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Excluded: install.find_package_consumer installs the library and links a consumer project
# without the sanitizer flags, which cannot link an ASan-built static library. It tests the
# packaging, not the code, and scripts/test.sh runs it on the Release build.
suite_start=$(date +%s)
ctest --test-dir "$BUILD" --output-on-failure --parallel "$JOBS" --timeout 1800 \
  -E '^install\.find_package_consumer$'
echo "ci_sanitize: ASan+UBSan suite $(( $(date +%s) - suite_start )) s"
fuzz_start=$(date +%s)
PRINTTWIN_FUZZ_PREBUILT=1 PRINTTWIN_FUZZ_BUILD_DIR="$BUILD" scripts/fuzz_smoke.sh "${1:-30}"
echo "ci_sanitize: fuzz smoke $(( $(date +%s) - fuzz_start )) s"
echo "ci_sanitize: total $(( $(date +%s) - start )) s"
