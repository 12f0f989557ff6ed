#!/usr/bin/env bash
# The container image's runtime stage without Docker (none runs on the project's machines):
# a Debian 12 minbase root (debootstrap) with exactly deploy/Dockerfile's runtime package
# list, this build installed into /opt/loam as the image does, then, inside it, a session
# with deploy/server.ini and the gpu backend (EGL on llvmpipe), loam-probe, a bot and a
# headless render of the live session. Needs root and the Debian archive; about 2 minutes.
# Usage: check-image-runtime.sh [BUILD_DIR]   (default build/release; not part of CI)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
root=$(mktemp -d)
server=""
cleanup() {
  if [ -n "$server" ]; then kill -TERM "$server" 2>/dev/null || true; wait "$server" 2>/dev/null || true; fi
  umount "$root/proc" "$root/dev" 2>/dev/null || true
  rm -rf "$root"
}
trap cleanup EXIT
command -v debootstrap >/dev/null || apt-get install -y -q debootstrap >/dev/null
debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian >/dev/null
packages=$(/usr/bin/python3 - <<'PY'
import re
d = open("deploy/Dockerfile").read()
block = d.split("# runtime-packages-begin")[1].split("# runtime-packages-end")[0]
print(" ".join(re.sub(r"\\\n", " ", block).split("--no-install-recommends")[1].split("&&")[0].split()))
PY
)
echo "check-image-runtime: installing $packages"
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"
chroot "$root" apt-get update -q >/dev/null
chroot "$root" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $packages >/dev/null
cmake --install "$build" --prefix "$root/opt/loam" --strip >/dev/null
mkdir -p "$root/etc/loam" "$root/var/lib/loam"
cp deploy/server.ini "$root/etc/loam/server.ini"
in_root() { chroot "$root" env XDG_CACHE_HOME=/tmp/.cache PATH=/opt/loam/bin:/usr/bin:/bin "$@"; }
in_root loam-server tokens new >"$root/etc/loam/tokens"
# Not through in_root: a function in the background is a subshell, and $! would be its pid.
chroot "$root" env XDG_CACHE_HOME=/tmp/.cache PATH=/opt/loam/bin:/usr/bin:/bin \
  loam-server --config /etc/loam/server.ini serve --bind 127.0.0.1 --port 0 --port-file /tmp/port \
  --backend gpu --stats-interval 0 2>"$root/server.log" &
server=$!  # chroot and env exec: this is the server's pid
for _ in $(seq 200); do [ -s "$root/tmp/port" ] && break; sleep 0.05; done
port=$(cat "$root/tmp/port")
in_root loam-probe --port "$port" --token-file /etc/loam/tokens
in_root loam-client bot --port "$port" --stamps 10 --rate 50 --token-file /etc/loam/tokens | tail -1
in_root loam-client render --server "127.0.0.1:$port" --token-file /etc/loam/tokens --size 160x90 --out /tmp/live.png |
  tail -1
test -s "$root/tmp/live.png"
grep -q 'event=backend requested=gpu chosen=gpu' "$root/server.log"
kill -TERM "$server"
wait "$server"  # exit 0: log durable, snapshot written
server=""
echo "check-image-runtime: ok ($(grep -o 'renderer="[^"]*"' "$root/server.log"))"
