#!/usr/bin/env bash
# Regenerates the committed replay logs and their expected hashes (per line: log, then the
# legacy content and world hashes (every tile), then the current ones (base plus edits)). The committed logs are format 1 and also pin that old logs still replay: a
# regeneration writes the current format, so keep the old files unless stamp semantics change.
# Usage: tests/golden/replay/regenerate.sh BUILD_DIR   (a configured build with tests)
# Only rerun when stamp semantics change on purpose: the hashes pin replay determinism.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:?usage: $0 BUILD_DIR}"
ninja -C "$build" loam_make_replay_logs
"$build/tests/loam_make_replay_logs" "$here" > "$here/expected.txt"
cat "$here/expected.txt"
