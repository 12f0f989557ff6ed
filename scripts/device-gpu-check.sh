#!/usr/bin/env bash
# Runs on a machine with a GPU, over the kit scripts/device-kit.sh built (copied beside the tree as .devkit):
# the GPU conformance tests (>= 1,000 random stamps, texel for texel against the CPU
# reference; CI=true, so a missing EGL display fails instead of skipping) and the gpu-stamps
# suite. Everything it writes goes to $OUT: gpu.txt, conformance.log, bench.log and
# gpu-stamps-results.tgz (the suite's report, CSVs and plot data). Runs without a GPU too, on llvmpipe.
set -uo pipefail
cd "$(dirname "$0")/.."

kit=${LOAM_DEVICE_KIT_DIR:-.devkit}
out=${OUT:-/tmp/loam-device-check}
mkdir -p "$out"
if [ ! -x "$kit/bin/loam-bench-gpu" ]; then
  echo "device-gpu-check: no kit in $kit: run scripts/device-kit.sh first and copy .devkit beside the tree" >&2
  exit 2
fi
echo "kit revision: $(cat "$kit/REVISION" 2>/dev/null || echo unknown)" | tee "$out/gpu.txt"

# glvnd's libEGL.so.1, unless the machine has one.
if ! ldconfig -p | grep -q 'libEGL\.so\.1 '; then
  for f in "$kit"/gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
# The NVIDIA EGL vendor file, where glvnd's default folders lack one.
if [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ] &&
  ! ls /usr/share/glvnd/egl_vendor.d/*nvidia* /etc/glvnd/egl_vendor.d/*nvidia* >/dev/null 2>&1; then
  for v in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json /usr/share/glvnd/egl_vendor.d/10_nvidia.json; do
    if [ -f "$v" ]; then
      export __EGL_VENDOR_LIBRARY_FILENAMES=$v
      break
    fi
  done
fi
{
  echo "EGL vendor file: ${__EGL_VENDOR_LIBRARY_FILENAMES:-glvnd default}"
  if command -v nvidia-smi >/dev/null; then nvidia-smi -L; else echo "nvidia-smi: not on this machine"; fi
} | tee -a "$out/gpu.txt"

# The kit's own glibc and loader; the machine's library path stays searchable for the driver.
lib_path="$PWD/$kit/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
run() { "$kit/lib/ld-linux-x86-64.so.2" --library-path "$lib_path" "$@"; }

CI=true run "$kit/bin/loam_gpu_conformance_tests" --gtest_brief=1 2>&1 | tee "$out/conformance.log"
conformance=${PIPESTATUS[0]}

work=$(mktemp -d)
run "$kit/bin/loam-bench-gpu" gpu-stamps --out "$work/results" 2>&1 | tee "$out/bench.log"
bench=${PIPESTATUS[0]}
tar czf "$out/gpu-stamps-results.tgz" -C "$work" results
rm -rf "$work"

echo "device-gpu-check: conformance exit $conformance, gpu-stamps exit $bench" | tee -a "$out/gpu.txt"
[ "$conformance" -eq 0 ] && [ "$bench" -eq 0 ]
