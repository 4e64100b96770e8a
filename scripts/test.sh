#!/usr/bin/env bash
# Same set-up as scripts/demo.sh, then the whole test suite through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
# The report tests drive a real browser (headless Chromium).
# The slicer back-end tests drive the real slicers (docs/compare.md); cura holds Cura's
# printer definitions. clang-format checks the code's formatting (.clang-format).
export PRINTTWIN_EXTRA_PACKAGES="${PRINTTWIN_EXTRA_PACKAGES:-} chromium prusa-slicer cura-engine cura slic3r clang-format"
scripts/setup.sh
scripts/lint.sh  # clang-format, then clang-tidy over src/ (about 9 min on 2 cores)
BUILD_DIR=${PRINTTWIN_BUILD_DIR:-build}
ctest --test-dir "$BUILD_DIR" --output-on-failure --parallel "$(nproc)" --timeout 900
