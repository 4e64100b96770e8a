#!/usr/bin/env bash
# The main job on a bundled sample: installs what is missing, builds printtwin, then verifies
# the 20 mm calibration cube with the built-in Ender-3 profile (printtwin slices it, runs
# the G-code on the simulated printer, deposits it as voxels and measures the deviation).
# The report lands in reports/calibration_cube_20mm/ (open report.html in a browser).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
BUILD_DIR=${PRINTTWIN_BUILD_DIR:-build}
echo
echo "\$ printtwin verify samples/models/calibration_cube_20mm.stl --out reports/calibration_cube_20mm"
set +e
"$BUILD_DIR/src/printtwin" verify samples/models/calibration_cube_20mm.stl \
  --out reports/calibration_cube_20mm
status=$?
set -e
echo
case $status in
  0) echo "printtwin: the part would print as designed (exit 0). Report: reports/calibration_cube_20mm/report.html" ;;
  1) echo "printtwin: the part would NOT print as designed (exit 1). Report: reports/calibration_cube_20mm/report.html" ;;
  *) echo "printtwin: the run failed (exit $status)"; exit "$status" ;;
esac
