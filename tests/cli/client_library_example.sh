#!/usr/bin/env bash
# The game library as a game would take it: `cmake --install --component client` into a temp
# prefix, the examples/crater project configured and built against that prefix alone, then
# both programs (C++ and C API) run against a real server on the embedded terrain, which
# requires tokens: each connects, digs a crater, and checks the crater it queries.
# Usage: client_library_example.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$1"
build="$2"
dir=$(mktemp -d)
server=
trap '[ -n "$server" ] && kill $server 2>/dev/null; wait 2>/dev/null || true; rm -rf "$dir"' EXIT
cmake --install "$build" --component client --prefix "$dir/prefix" > "$dir/install.log"
test -f "$dir/prefix/include/loam_client.h"
test -f "$dir/prefix/include/loam/client.hpp"
ls "$dir"/prefix/lib*/cmake/LoamClient/LoamClientConfig.cmake > /dev/null
# Nothing of the source tree: only the installed prefix is on the search path.
cmake -S "$src/examples/crater" -B "$dir/example" -G Ninja -DCMAKE_PREFIX_PATH="$dir/prefix" \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo > "$dir/configure.log"
ninja -C "$dir/example" > "$dir/build.log" || { cat "$dir/build.log"; exit 1; }

"$build/server/loam-server" tokens new > "$dir/tokens"
editor=$(sed -n 's/^editor //p' "$dir/tokens")
"$build/server/loam-server" serve --port 0 --port-file "$dir/port" --data-dir "$dir/data" --stats-interval 0 \
  --tokens-file "$dir/tokens" 2> "$dir/server.log" &
server=$!
for _ in $(seq 300); do [ -s "$dir/port" ] && break; sleep 0.05; done
port=$(cat "$dir/port")
# Without the token the library reports why it cannot join.
if "$dir/example/loam-crater" 127.0.0.1 "$port" 2> "$dir/refused.txt"; then
  echo "client_library_example: joined without a token" >&2
  exit 1
fi
cat "$dir/refused.txt"
LOAM_TOKEN=$editor "$dir/example/loam-crater" 127.0.0.1 "$port"
LOAM_TOKEN=$editor "$dir/example/loam-crater-c" 127.0.0.1 "$port"
kill -INT $server
wait $server
echo "client_library_example: ok"
