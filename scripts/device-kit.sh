#!/usr/bin/env bash
# Builds the kit that measures Loam's GPU paths on a machine with a GPU where none of our
# Debian libraries are installed. The kit, in .devkit/ (ignored):
#   bin/  loam_gpu_conformance_tests, loam-bench-gpu (Release, libstdc++ linked in)
#   lib/  their shared libraries and this machine's glibc with its loader, so the binaries run
#         whatever the other machine's C library is
#   gl/   Debian's glvnd loader packages (libEGL.so.1 and friends), unpacked there only when
#         that machine has no libEGL.so.1
# Then, on that machine, with .devkit beside the working tree: bash scripts/device-gpu-check.sh
set -euo pipefail
cd "$(dirname "$0")/.."

kit=.devkit
cmake -S . -B build/device -G Ninja -DCMAKE_BUILD_TYPE=Release -DLOAM_DEVICE_KIT=ON -DLOAM_BUILD_TESTS=ON >/dev/null
ninja -C build/device loam-bench-gpu loam_gpu_conformance_tests

rm -rf "$kit"
mkdir -p "$kit/bin" "$kit/lib" "$kit/gl"
cp build/device/bench/loam-bench-gpu build/device/tests/loam_gpu_conformance_tests "$kit/bin/"
strip "$kit/bin/"*

# Every shared library the binaries load, glibc included (resolved through the links).
for b in "$kit/bin/"*; do
  ldd "$b" | awk '/=>/ {print $3} $1 ~ /ld-linux/ {print $1}'
done | sort -u | while read -r lib; do
  cp -L "$lib" "$kit/lib/$(basename "$lib")"
done

# The GL vendor-neutral loaders: the NVIDIA driver brings only its vendor libraries.
(cd "$kit/gl" && apt-get download -q libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2 >/dev/null 2>&1)

git rev-parse HEAD >"$kit/REVISION"
echo "device-kit: $(du -sh "$kit" | cut -f1) in $kit ($(ls "$kit/lib" | wc -l) libraries, $(ls "$kit/gl" | wc -l) packages)"
