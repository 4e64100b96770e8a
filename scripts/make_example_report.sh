#!/bin/sh
# Regenerates the committed example report (reports/example/) and the README screenshot
# (docs/img/report.png) from a bundled sample: PrusaSlicer's G-code of the thin-wall part,
# whose walls thinner than a line are dropped by the slicer (so the report has something to
# show). docs/reports.md describes the report.
#   scripts/make_example_report.sh        # CLI from build/ (PRINTTWIN_BUILD_DIR to change)
# Needs the built CLI and, for the screenshot, chromium (or PRINTTWIN_CHROMIUM).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"  # relative input paths, so that the report does not carry this machine's paths
build=${PRINTTWIN_BUILD_DIR:-build}
cli=$build/src/printtwin
if [ ! -x "$cli" ]; then
  echo "make_example_report: build the CLI first (cmake --build $build --target printtwin_cli)" >&2
  exit 2
fi
# Reports are byte-for-byte reproducible except for the generation time and the stage
# timings: pin the time to the last commit's.
SOURCE_DATE_EPOCH=${SOURCE_DATE_EPOCH:-$(git log -1 --format=%ct 2>/dev/null || echo 0)}
export SOURCE_DATE_EPOCH

status=0
"$cli" verify samples/models/thin_walls.stl --gcode samples/gcode/prusa_thin_walls.gcode \
  --out reports/example || status=$?
# Exit 1 = the part fails its gates, which is what this example shows; more is an error.
if [ "$status" -gt 1 ]; then exit "$status"; fi

browser=${PRINTTWIN_CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}
if [ -z "$browser" ]; then
  echo "make_example_report: chromium not found; report written, screenshot not updated" >&2
  exit 0
fi
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
mkdir -p docs/img
"$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --hide-scrollbars --user-data-dir="$profile" --window-size=1400,1180 \
  --screenshot="$here/docs/img/report.png" "file://$here/reports/example/report.html" 2>/dev/null
echo "reports/example/ and docs/img/report.png updated"
