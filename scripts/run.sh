#!/usr/bin/env bash
# The README's main command: sets up the machine, builds Loam (release) and runs the main
# job. For now that loads the embedded default terrain and prints its summary; it grows into
# a server with a viewer and bots as those land.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOAM_BUILD_TESTS=OFF >/dev/null
ninja -C build/release -j "$(nproc)"
./build/release/app/loam summary "$@"
