#!/usr/bin/env bash
# Builds loam-bench without sanitizers (release) and runs the given suites (default: all),
# writing bench/results/. Example: scripts/bench.sh import codec
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOAM_BUILD_TESTS=OFF >/dev/null
ninja -C build/release -j "$(nproc)" loam-bench
if [ $# -eq 0 ]; then
  set -- $(./build/release/bench/loam-bench --list | awk '{print $1}')
fi
./build/release/bench/loam-bench "$@"
