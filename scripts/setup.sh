#!/usr/bin/env bash
# Installs the Debian packages printtwin needs (only those missing; quiet when all are
# present), then configures and builds printtwin in Release under build/.
# Usage: scripts/setup.sh [--packages-only]   (as root, or with sudo available, on Debian 12)
# PRINTTWIN_EXTRA_PACKAGES adds packages; --packages-only stops after installing them.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(build-essential cmake pkg-config ccache
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev libassimp-dev liboctomap-dev libeigen3-dev
  libembree-dev libpolyclipping-dev libtbb-dev libcli11-dev nlohmann-json3-dev
  libfmt-dev libgtest-dev libgmock-dev libbenchmark-dev libpng-dev libstb-dev zlib1g-dev
  libdeflate-dev)
PACKAGES+=(${PRINTTWIN_EXTRA_PACKAGES:-})

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "printtwin setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
[ "${1:-}" = "--packages-only" ] && exit 0

BUILD_DIR=${PRINTTWIN_BUILD_DIR:-build}
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DPRINTTWIN_WERROR=ON "${launcher[@]}" \
  ${PRINTTWIN_CMAKE_ARGS:-} >/dev/null
log="$BUILD_DIR/build.log"
if ! cmake --build "$BUILD_DIR" --parallel "$(nproc)" >"$log" 2>&1; then
  grep -E -A5 'error|Error' "$log" | head -60
  echo "printtwin setup: build failed (full log: $log)" >&2
  exit 1
fi
