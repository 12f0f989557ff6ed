#!/usr/bin/env bash
# Smoke run of the viewer against a real server, as the main job runs it: a server on the
# embedded terrain, a bot deforming it, the headless viewer stamping at its view's centre
# (exit 0 means no hash mismatch and no GPU/CPU divergence), and where a display exists (ctest
# runs under xvfb-run in scripts/test.sh) the windowed viewer for a few frames with a
# screenshot of its HUD; then `loam-client render` of the live session and, after the server
# stopped (writing a snapshot), of its data folder. The server requires tokens (a
# `loam-server tokens new` file), which every client presents its own way: the bot and the
# windowed viewer with --token-file, the headless viewer through LOAM_TOKEN, the render with
# the viewer token. Usage: viewer_smoke.sh BUILD_DIR
set -euo pipefail
build="$1"
dir=$(mktemp -d)
trap 'kill $server 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$dir"' EXIT
"$build/server/loam-server" tokens new > "$dir/tokens"
editor=$(sed -n 's/^editor //p' "$dir/tokens")
"$build/server/loam-server" serve --port 0 --port-file "$dir/port" --data-dir "$dir/data" --stats-interval 0 \
  --tokens-file "$dir/tokens" 2> "$dir/server.log" &
server=$!
for _ in $(seq 300); do [ -s "$dir/port" ] && break; sleep 0.05; done
port=$(cat "$dir/port")
"$build/client/loam-client" bot --port "$port" --stamps 40 --rate 20 --seed 5 --token-file "$dir/tokens" \
  > "$dir/bot.log" &
bot=$!
LOAM_TOKEN=$editor "$build/client/loam-client" view --headless --port "$port" --seconds 4 --stamp-every 1 \
  --size 320x180 --screenshot "$dir/headless.png"
test -s "$dir/headless.png"
if [ -n "${DISPLAY:-}" ]; then
  "$build/client/loam-client" view --port "$port" --seconds 2 --size 480x270 --no-vsync --screenshot "$dir/window.png" \
    --token-file "$dir/tokens"
  test -s "$dir/window.png"
else
  echo "viewer_smoke: no DISPLAY, the window viewer was not run"
fi
wait $bot
cat "$dir/bot.log"
# Without a token the live render is refused; with the viewer token it draws.
if "$build/client/loam-client" render --server "127.0.0.1:$port" --size 16x9 --out "$dir/refused.png" 2> "$dir/refused.txt"; then
  echo "viewer_smoke: a render without a token was let in" >&2
  exit 1
fi
grep -q "requires an access token" "$dir/refused.txt"
"$build/client/loam-client" render --server "127.0.0.1:$port" --camera 900,1300,420 --look 1000,700,40 \
  --size 160x90 --out "$dir/live.png" --token-file "$dir/tokens"
test -s "$dir/live.png"
kill -INT $server
wait $server
"$build/client/loam-client" render --snapshot "$dir/data" --camera 900,1300,420 --look 1000,700,40 \
  --size 160x90 --out "$dir/snapshot.png"
test -s "$dir/snapshot.png"
# The live session's confirmed tiles and the snapshot hold the same terrain: same picture.
cmp "$dir/live.png" "$dir/snapshot.png"
echo "viewer_smoke: ok"
