#!/usr/bin/env bash
# deploy/ without Docker, Kubernetes or a running systemd: what can drift is checked here.
#  1. `cmake --install` of the build, and the installed programs run from the prefix.
#  2. The server runs exactly as deploy/systemd/loam-server@.service's ExecStart says (paths
#     moved into a temporary root), with deploy/server.ini and a `loam-server tokens new` file:
#     probes with the viewer token, refuses a client with none, takes a bot's stamps with the
#     editor token, stops on SIGTERM with exit 0 and a snapshot, and recovers to the same
#     sequence. A misspelt key in the ini file stops it at start.
#  3. `systemd-analyze verify` of the unit.
#  4. tests/deploy/check_manifests.py: every flag the Dockerfile, compose files and
#     Kubernetes manifests pass exists, and the image installs a package for every library
#     the programs link.
# Usage: deploy_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$1"
build="$2"
root=$(mktemp -d)
server=""
cleanup() {
  if [ -n "$server" ]; then kill -9 "$server" 2>/dev/null || true; fi
  rm -rf "$root"
}
trap cleanup EXIT
fail() {
  echo "deploy_test: FAIL: $*" >&2
  for f in "$root"/server*.log; do [ -f "$f" ] && { echo "--- $f"; cat "$f"; } >&2; done
  exit 1
}

echo "== 1. cmake --install"
cmake --install "$build" --prefix "$root/prefix" >"$root/install.log" || fail "cmake --install: $(cat "$root/install.log")"
bin="$root/prefix/bin"
for p in loam-server loam-client loam-probe loam; do test -x "$bin/$p" || fail "$p not installed"; done
test -f "$root/prefix/share/loam/server.ini" || fail "server.ini not installed"
test -f "$root/prefix/share/loam/loam-server@.service" || fail "the unit not installed"
test -f "$root/prefix/share/doc/loam/deploy.md" || fail "deploy.md not installed"
"$bin/loam-server" --version | grep -q "protocol 6\." || fail "loam-server --version"
"$bin/loam-client" --version | grep -q "protocol 6\." || fail "loam-client --version"

echo "== 2. the server as the systemd unit runs it"
unit="$src/deploy/systemd/loam-server@.service"
instance=demo
mkdir -p "$root/etc/loam" "$root/var/lib/loam" "$root/credentials"
cp "$src/deploy/server.ini" "$root/etc/loam/$instance.ini"
"$bin/loam-server" tokens new >"$root/etc/loam/$instance.tokens"
grep -c '^editor [0-9a-f]\{32\}$' "$root/etc/loam/$instance.tokens" | grep -qx 1 || fail "tokens new: no editor line"
grep -c '^viewer [0-9a-f]\{32\}$' "$root/etc/loam/$instance.tokens" | grep -qx 1 || fail "tokens new: no viewer line"
cp "$root/etc/loam/$instance.tokens" "$root/credentials/tokens"  # what LoadCredential= does
exec_start=$(sed -n 's/^ExecStart=//p' "$unit")
[ -n "$exec_start" ] || fail "no ExecStart in the unit"
# The unit's specifiers and absolute paths, moved into the temporary root.
cmdline=${exec_start//%i/$instance}
cmdline=${cmdline//%d/$root/credentials}
cmdline=${cmdline//\/usr\/local\/bin\//$bin/}
cmdline=${cmdline//\/etc\/loam\//$root/etc/loam/}
cmdline=${cmdline//\/var\/lib\/loam\//$root/var/lib/loam/}
read -r -a argv <<<"$cmdline"
# Loopback and an ephemeral port for the test; flags after `serve` override the ini file.
extra=(--bind 127.0.0.1 --port 0 --port-file "$root/port" --stats-interval 0)
data="$root/var/lib/loam/$instance"

start_server() {
  rm -f "$root/port"
  "${argv[@]}" "${extra[@]}" 2>"$root/server.$1.log" &
  server=$!
  for _ in $(seq 600); do
    [ -s "$root/port" ] && return 0
    kill -0 "$server" 2>/dev/null || fail "the server exited at start"
    sleep 0.05
  done
  fail "the server did not come up"
}
stop_server() {
  kill -TERM "$server"
  local rc=0
  wait "$server" || rc=$?
  server=""
  [ "$rc" -eq 0 ] || fail "SIGTERM: exit code $rc, expected 0"
}

start_server 1
port=$(cat "$root/port")
tokens="$root/etc/loam/$instance.tokens"
grep -q "event=listening .*access=tokens editor_tokens=1 viewer_tokens=1" "$root/server.1.log" ||
  fail "the server did not take the tokens file"
probe=$("$bin/loam-client" probe --port "$port" --token-file "$tokens") || fail "probe with the viewer token"
echo "$probe"
echo "$probe" | grep -q "role spectator" || fail "probe with the viewer token was not a spectator"
if "$bin/loam-client" probe --port "$port" --timeout 3 2>"$root/refused.txt"; then
  fail "a probe without a token was let in"
fi
grep -q "requires an access token" "$root/refused.txt" || fail "refusal without a reason: $(cat "$root/refused.txt")"
"$bin/loam-client" bot --port "$port" --stamps 20 --rate 100 --seed 3 --token-file "$tokens" >"$root/bot.txt" ||
  fail "bot: $(cat "$root/bot.txt")"
grep -q "20/20 stamps accepted" "$root/bot.txt" || fail "bot: $(cat "$root/bot.txt")"
json=$("$bin/loam-probe" --port "$port" --token-file "$tokens" --json) || fail "loam-probe --json"
echo "$json" | grep -q '"sequence":20,' || fail "probe after 20 stamps: $json"
stop_server
ls "$data/snapshots" | grep -q "snapshot-0*20$" || fail "no shutdown snapshot at sequence 20: $(ls "$data/snapshots")"

start_server 2
port=$(cat "$root/port")
grep -q "event=recovered .*last_seq=20" "$root/server.2.log" || fail "no recovery to sequence 20"
LOAM_TOKEN=$(sed -n 's/^viewer //p' "$tokens") "$bin/loam-probe" --port "$port" --json | grep -q '"sequence":20,' ||
  fail "loam-probe (LOAM_TOKEN) after recovery"
if "$bin/loam-probe" --port "$port" --token 0123456789abcdef0123456789abcdef --timeout 3 2>"$root/wrong.txt"; then
  fail "a probe with a wrong token was let in"
fi
grep -q "wrong access token" "$root/wrong.txt" || fail "refusal without a reason: $(cat "$root/wrong.txt")"
stop_server

# A misspelt key is an error at start, not a default kept quietly.
sed 's/^tick-hz = /tick-hertz = /' "$src/deploy/server.ini" >"$root/etc/loam/$instance.ini"
if "${argv[@]}" "${extra[@]}" 2>"$root/misspelt.txt"; then fail "a misspelt ini key was accepted"; fi
grep -q "tick-hertz" "$root/misspelt.txt" || fail "the misspelt key was not named: $(cat "$root/misspelt.txt")"

echo "== 3. systemd-analyze verify"
if command -v systemd-analyze >/dev/null; then
  # verify wants the unit's binary to exist: point it at the installed one.
  sed "s|/usr/local/bin/|$bin/|" "$unit" >"$root/loam-server@$instance.service"
  if ! systemd-analyze verify "$root/loam-server@$instance.service" >"$root/verify.txt" 2>&1; then
    fail "systemd-analyze verify: $(cat "$root/verify.txt")"
  fi
  # verify also reports problems of the host's own units; ours must be clean.
  if grep "loam-server@" "$root/verify.txt"; then fail "systemd-analyze verify found problems in the unit"; fi
else
  fail "systemd-analyze missing (scripts/setup.sh installs systemd)"
fi

echo "== 4. manifests"
/usr/bin/python3 "$src/tests/deploy/check_manifests.py" "$src" "$bin"

echo "deploy_test: ok"
