#!/usr/bin/env bash
# The README's main command: sets up the machine, builds Loam (release) and runs the main
# job: a loam-server session on the default world (the embedded ETOPO5 crop refined to
# 131 x 98 km at 1 m, generated on demand; data folder ./loam-data, port 7878) with two
# roaming bots deforming it and a viewer: a window when there is a display (fly with
# WASD and the right mouse button, click to deform; with LOAM_VIEW_SECONDS it closes after
# that long with a screenshot), otherwise the headless viewer, which
# orbits the terrain for LOAM_VIEW_SECONDS (default 30), stamps at its view's centre every 2 s
# and writes screenshots to the data folder. The server keeps running until Ctrl-C (or for
# LOAM_RUN_SECONDS seconds after the bots and the viewer are done), then shuts down cleanly
# (log flushed, snapshot written).
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
# LOAM_BUILD_DIR: run the programs of another, already configured build (the test suite's
# smoke run of this script uses its own sanitized build); default: a release build here.
build="${LOAM_BUILD_DIR:-build/release}"
if [ -z "${LOAM_BUILD_DIR:-}" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOAM_BUILD_TESTS=OFF >/dev/null
fi
ninja -C "$build" -j "$(nproc)" loam loam-server loam-client loam-probe

port="${LOAM_PORT:-7878}"
data="${LOAM_DATA_DIR:-loam-data}"
"$build"/app/loam summary
"$build"/server/loam-server serve --terrain refined --cache-mb 256 --port "$port" --data-dir "$data" \
  --backend auto "$@" &
server=$!
trap 'kill -INT $server 2>/dev/null; wait $server' INT TERM
for _ in $(seq 300); do  # until a real handshake works (recovery can replay a long log first)
  "$build"/client/loam-probe --port "$port" --timeout 1 2>/dev/null && break
  sleep 0.2
done
"$build"/client/loam-client bot --port "$port" --name bot-a --seed 1 --stamps 200 --rate 20 --roam 20 &
bot_a=$!
"$build"/client/loam-client bot --port "$port" --name bot-b --seed 2 --stamps 200 --rate 20 --roam 20 &
bot_b=$!
if [ -n "${DISPLAY:-}" ]; then
  # LOAM_VIEW_SECONDS: close the window after that long, with a screenshot of its last frame.
  seconds=()
  if [ -n "${LOAM_VIEW_SECONDS:-}" ]; then seconds=(--seconds "$LOAM_VIEW_SECONDS" --screenshot "$data/viewer.png"); fi
  "$build"/client/loam-client view --port "$port" --name viewer "${seconds[@]}" &
else
  echo "loam: no display: the viewer runs headless (screenshots in $data/viewer_*.png)"
  "$build"/client/loam-client view --headless --port "$port" --name viewer \
    --seconds "${LOAM_VIEW_SECONDS:-30}" --stamp-every 2 --screenshot-every 10 --screenshot "$data/viewer.png" &
fi
viewer=$!
wait $bot_a $bot_b $viewer || true
"$build"/client/loam-probe --port "$port" || true
if [ -n "${LOAM_RUN_SECONDS:-}" ]; then
  sleep "$LOAM_RUN_SECONDS"
  kill -INT $server
else
  echo "loam: server running on port $port with data in $data; Ctrl-C to stop"
fi
wait $server
