#!/usr/bin/env bash
# Regenerates bench/results/hostile-files.md and .csv: hostile DEM files (truncated, huge
# headers, corrupt bytes, colour images, wrong sidecars, NaN-only...) against
# `loam-server import`, with each one's error, exit code and peak RSS.
# Usage: scripts/hostile-files.sh [BUILD_DIR]   (default build/release, built here if absent)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
if [ ! -x "$build/server/loam-server" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOAM_BUILD_TESTS=OFF >/dev/null
  ninja -C "$build" loam-server
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 scripts/hostile_files.py --server "$build/server/loam-server" --out "$work" \
  --table bench/results/hostile-files
