#!/usr/bin/env bash
# Profiles a cold build of the README's test configuration (GCC, ASan + UBSan, no compiler
# cache) and writes bench/results/build.md and .csv: wall time, compile seconds per target
# and per heavy header, the slowest steps (scripts/build_profile.py).
# Usage: scripts/build-profile.sh [extra cmake arguments], e.g. -DLOAM_UNITY_BUILD=OFF
# to profile the build without unity batches. Takes the machine for the whole build.
set -euo pipefail
cd "$(dirname "$0")/.."
build=$(mktemp -d)
trap 'rm -rf "$build"' EXIT
export CCACHE_DISABLE=1
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLOAM_SANITIZE=ON "$@" >/dev/null
start=$(date +%s)
ninja -C "$build" -j "$(nproc)" >/dev/null
end=$(date +%s)
python3 scripts/build_profile.py "$build" --table bench/results/build --title "build: cold sanitizer build" \
  --note "A cold build of the test configuration (GCC $(gcc -dumpfullversion), ASan + UBSan, RelWithDebInfo, no compiler cache), $(nproc) jobs on $(nproc) hardware threads ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)), $((end - start)) s by the clock. cmake arguments: ${*:-none}."
