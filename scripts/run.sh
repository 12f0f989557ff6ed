#!/usr/bin/env bash
# The README's main command: sets up the machine, builds Loam (release) and runs the main
# job: a loam-server session on the embedded default terrain (data folder ./loam-data, port
# 7878) with two bots deforming it; the server keeps running until Ctrl-C (or for
# LOAM_RUN_SECONDS seconds), then shuts down cleanly (log flushed, snapshot written).
# The GPU viewer joins this job when the client-rendering issue lands.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOAM_BUILD_TESTS=OFF >/dev/null
ninja -C build/release -j "$(nproc)" loam loam-server loam-client

port="${LOAM_PORT:-7878}"
data="${LOAM_DATA_DIR:-loam-data}"
./build/release/app/loam summary
./build/release/server/loam-server serve --port "$port" --data-dir "$data" --backend auto "$@" &
server=$!
trap 'kill -INT $server 2>/dev/null; wait $server' INT TERM
for _ in $(seq 100); do  # wait until it accepts connections
  (exec 3<>/dev/tcp/127.0.0.1/"$port") 2>/dev/null && break
  sleep 0.1
done
./build/release/client/loam-client bot --port "$port" --name bot-a --seed 1 --stamps 200 --rate 20 &
bot_a=$!
./build/release/client/loam-client bot --port "$port" --name bot-b --seed 2 --stamps 200 --rate 20 &
bot_b=$!
wait $bot_a $bot_b || true
if [ -n "${LOAM_RUN_SECONDS:-}" ]; then
  sleep "$LOAM_RUN_SECONDS"
  kill -INT $server
else
  echo "loam: server running on port $port with data in $data; Ctrl-C to stop"
fi
wait $server
