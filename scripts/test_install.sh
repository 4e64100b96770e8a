#!/usr/bin/env bash
# Installs printtwin from an existing build dir into a temporary prefix, then configures,
# builds and runs examples/consumer against it with find_package(printtwin).
# Usage: scripts/test_install.sh <build-dir> <work-dir>
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
build=$1
work=$2
rm -rf "$work"
cmake --install "$build" --prefix "$work/prefix" >/dev/null
cmake -S "$src/examples/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/consumer" >/dev/null
out=$("$work/consumer/consumer" "$src/samples/models/calibration_cube_20mm.stl")
echo "$out"
# A 20 mm cube holds 8000 mm3.
echo "$out" | grep -q "volume_mm3 8000.000"
