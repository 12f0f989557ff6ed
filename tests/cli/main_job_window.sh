#!/usr/bin/env bash
# The README's main command with a display, as a new user on a desktop runs it: scripts/run.sh
# serves the refined 131 km world with two bots and opens the viewer in a window (under the
# X display ctest runs in: xvfb-run in scripts/test.sh) for LOAM_VIEW_SECONDS, using this
# build's programs (LOAM_BUILD_DIR). The window must have drawn terrain over most of its last
# frame (the viewer reads the share from its depth buffer) and written its screenshot.
# Usage: main_job_window.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$1"
build="$2"
if [ -z "${DISPLAY:-}" ]; then
  if [ "${CI:-}" = "true" ]; then echo "main_job_window: no DISPLAY in CI" >&2; exit 1; fi
  echo "main_job_window: no DISPLAY, skipped (scripts/test.sh runs ctest under xvfb-run)"
  echo "main_job_window: ok"
  exit 0
fi
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
port=$((20000 + RANDOM % 20000))
# Mesa's GLX driver leaves a few bytes at exit in a module LeakSanitizer cannot name (as for
# every GL test): leaks are not checked here.
(cd "$src" && ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0" LOAM_BUILD_DIR="$build" \
  LOAM_PORT="$port" LOAM_DATA_DIR="$dir/data" LOAM_VIEW_SECONDS=6 LOAM_RUN_SECONDS=0 \
  bash scripts/run.sh) > "$dir/run.log" 2>&1 || { cat "$dir/run.log"; exit 1; }
cat "$dir/run.log"
covered=$(sed -n 's/^viewer window: terrain covers \([0-9.]*\)% of the view/\1/p' "$dir/run.log" | tail -1)
echo "main_job_window: the window's last frame shows terrain over ${covered:-?}% of the view"
test -s "$dir/data/viewer.png"
awk -v c="$covered" 'BEGIN { exit !(c != "" && c > 50) }'
echo "main_job_window: ok"
