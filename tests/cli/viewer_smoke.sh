#!/usr/bin/env bash
# Smoke run of the viewer against a real server, as the main job runs it: a server on the
# embedded terrain, a bot deforming it, the headless viewer stamping at its view's centre
# (exit 0 means no hash mismatch and no GPU/CPU divergence), walking (a crater dug under the
# walker, which must fall in and stand on its floor), and where a display exists (ctest
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
# Walk mode: a walker at the centre; a crater dug under it at 2 s; it falls in and stands on the
# floor (12 s: the first frames of a sanitized build under load can take seconds).
LOAM_TOKEN=$editor "$build/client/loam-client" view --headless --port "$port" --walk --dig-under 2 --seconds 12 \
  --size 320x180 --screenshot "$dir/walker.png" | tee "$dir/walk.log"
test -s "$dir/walker.png"
dug_z=$(sed -n 's/.*dug a crater under the walker .*feet at \([-0-9.]*\) m.*/\1/p' "$dir/walk.log")
end_z=$(sed -n 's/^viewer walker: feet at [-0-9.]*, [-0-9.]*, \([-0-9.]*\) m.*standing.*/\1/p' "$dir/walk.log")
echo "viewer_smoke: walker feet at ${dug_z} m when dug, ${end_z} m standing at the end"
awk -v a="$dug_z" -v b="$end_z" 'BEGIN { exit !(a != "" && b != "" && b < a - 1.0) }'
if [ -n "${DISPLAY:-}" ]; then
  # Mesa's GLX driver is unloaded at exit with a few bytes it never freed (an unnamed module to
  # LeakSanitizer, so no suppression can name it): leaks are not checked for the window, as for
  # every GL test.
  ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0" "$build/client/loam-client" view --port "$port" --seconds 2 --size 480x270 --no-vsync --screenshot "$dir/window.png" \
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

# The main job's world: the refined default (131 x 98 km at 1 m). The viewer generates the
# untouched tiles itself and holds only what it sees: its terrain memory stays within the
# 256 MiB of GPU memory and the 1 GiB the world-scale issue allows, with a roaming bot deforming.
"$build/server/loam-server" serve --terrain refined --cache-mb 64 --port 0 --port-file "$dir/rport" \
  --data-dir "$dir/rdata" --stats-interval 0 2> "$dir/rserver.log" &
server=$!
for _ in $(seq 300); do [ -s "$dir/rport" ] && break; sleep 0.05; done
rport=$(cat "$dir/rport")
"$build/client/loam-client" bot --port "$rport" --stamps 20 --rate 10 --seed 6 --roam 20 > "$dir/rbot.log" &
bot=$!
"$build/client/loam-client" view --headless --port "$rport" --seconds 4 --stamp-every 1 --size 320x180 \
  --screenshot "$dir/refined.png" | tee "$dir/rview.log"
test -s "$dir/refined.png"
wait $bot
cat "$dir/rbot.log"
gpu_mib=$(sed -n 's/.*terrain memory GPU \([0-9.]*\) MiB.*/\1/p' "$dir/rview.log" | tail -1)
cpu_mib=$(sed -n 's/.*MiB (.*), CPU \([0-9.]*\) MiB.*/\1/p' "$dir/rview.log" | tail -1)
echo "viewer_smoke: refined world, viewer terrain memory GPU ${gpu_mib} MiB, CPU ${cpu_mib} MiB"
awk -v g="$gpu_mib" -v c="$cpu_mib" 'BEGIN { exit !(g > 0 && g <= 256 && c > 0 && c <= 1024) }'
kill -INT $server
wait $server
echo "viewer_smoke: ok"
