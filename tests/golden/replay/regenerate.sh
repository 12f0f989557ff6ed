#!/usr/bin/env bash
# Regenerates the committed replay logs and their expected world hashes.
# Usage: tests/golden/replay/regenerate.sh BUILD_DIR   (a configured build with tests)
# Only rerun when stamp semantics change on purpose: the hashes pin replay determinism.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:?usage: $0 BUILD_DIR}"
ninja -C "$build" loam_make_replay_logs
"$build/tests/loam_make_replay_logs" "$here" > "$here/expected.txt"
cat "$here/expected.txt"
