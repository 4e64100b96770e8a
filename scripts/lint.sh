#!/usr/bin/env bash
# Style and static checks.
#   scripts/lint.sh            both checks
#   scripts/lint.sh --format   clang-format --dry-run --Werror over the C++ sources
#   scripts/lint.sh --tidy     clang-tidy (.clang-tidy) over src/ with the build's
#                              compile_commands.json, in parallel (run-clang-tidy)
# Environment: PRINTTWIN_BUILD_DIR (default build), LINT_JOBS (default nproc).
# Exits non-zero on any formatting difference or clang-tidy finding.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-all}
BUILD_DIR=${PRINTTWIN_BUILD_DIR:-build}
JOBS=${LINT_JOBS:-$(nproc)}
status=0

if [ "$mode" = all ] || [ "$mode" = --format ]; then
  mapfile -t files < <(find src include tests bench fuzz examples -type f \
    \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' -o -name '*.cc' \) | sort)
  echo "lint: clang-format on ${#files[@]} files"
  if ! printf '%s\0' "${files[@]}" | xargs -0 -n 50 -P "$JOBS" clang-format --dry-run --Werror; then
    echo "lint: formatting differs; fix with: clang-format -i FILE" >&2
    status=1
  fi
fi

if [ "$mode" = all ] || [ "$mode" = --tidy ]; then
  # The Debian package clang-tidy brings clang-tidy and run-clang-tidy.
  command -v run-clang-tidy >/dev/null || PRINTTWIN_EXTRA_PACKAGES=clang-tidy scripts/setup.sh --packages-only
  db="$BUILD_DIR/compile_commands.json"
  if [ ! -f "$db" ]; then
    echo "lint: $db missing; configure first (scripts/setup.sh)" >&2
    exit 2
  fi
  echo "lint: clang-tidy on src/ with $JOBS jobs"
  start=$(date +%s)
  times >"$BUILD_DIR/clang-tidy.cpu"  # this shell's children's CPU time so far (a builtin: no fork)
  log="$BUILD_DIR/clang-tidy.log"
  # The database holds GCC's flags: clang ignores the GCC-only warning options and
  # attributes, and reports its own compiler warnings as warnings, not errors (the GCC
  # build with -Werror owns compiler warnings; .clang-tidy filters clang-diagnostic-*).
  # Colours off.
  run-clang-tidy -p "$BUILD_DIR" -j "$JOBS" -quiet \
    -extra-arg=-Wno-unknown-warning-option -extra-arg=-Wno-unknown-attributes \
    -extra-arg=-Wno-error "$PWD/src/.*\.cpp\$" 2>&1 |
    sed 's/\x1b\[[0-9;]*m//g' >"$log" || true
  # A finding in a header is reported once per source file that includes it: count and
  # show each place once.
  awk '/^\/.*: (warning|error):/ {show = !seen[$0]++; n = 4} n > 0 && show {print} {n--}' "$log"
  findings=$({ grep -E '^/.*: (warning|error):' "$log" || true; } | sort -u | wc -l)
  times >>"$BUILD_DIR/clang-tidy.cpu"
  cpu=$(awk '{for (i = 1; i <= 2; ++i) {split($i, t, /[ms]/); s += (NR == 4 ? 1 : NR == 2 ? -1 : 0) * (60 * t[1] + t[2])}}
    END {printf "%.0f", s}' "$BUILD_DIR/clang-tidy.cpu")
  echo "lint: clang-tidy found $findings issue(s) in $(( $(date +%s) - start )) s wall, $cpu s CPU (log: $log)"
  [ "$findings" -eq 0 ] || status=1
fi
exit $status
