#!/usr/bin/env bash
# The README's test command: sets up the machine, builds every test in one configuration
# (GCC, AddressSanitizer + UndefinedBehaviorSanitizer, warnings as errors) and runs them
# under ctest; then builds protocol/ with clang 14, runs each libFuzzer target briefly and
# checks that clang's build of the stamp code reproduces the golden stamp-sequence hash.
# Environment: LOAM_FUZZ_SECONDS (default 20), LOAM_SKIP_FUZZ=1 to skip the fuzzers.
set -euo pipefail
cd "$(dirname "$0")/.."

# Each phase's wall time, printed at the end (README: the cold time of this command).
phase_names=() phase_secs=() phase_start=$SECONDS
end_phase() { phase_names+=("$1"); phase_secs+=($((SECONDS - phase_start))); phase_start=$SECONDS; }

bash scripts/setup.sh
end_phase setup

export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$PWD/tests/lsan.supp:print_suppressions=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
jobs=$(nproc)

echo "== build (gcc, asan+ubsan)"
cmake -S . -B build/asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLOAM_SANITIZE=ON >/dev/null
ninja -C build/asan -j "$jobs"
end_phase build

echo "== tests"
# Window tests (GLFW) need an X display: run ctest under a virtual one when there is none.
xvfb=()
if [ -z "${DISPLAY:-}" ] && command -v xvfb-run >/dev/null; then xvfb=(xvfb-run -a -s "-screen 0 1280x1024x24"); fi
(cd build/asan && "${xvfb[@]}" ctest --output-on-failure -j "$jobs" --timeout 900)
end_phase tests

if [ "${LOAM_SKIP_FUZZ:-0}" != "1" ] && [ -f fuzz/CMakeLists.txt ]; then
  echo "== fuzz (clang 14 build of protocol/, ${LOAM_FUZZ_SECONDS:-20} s per target)"
  bash fuzz/run.sh all "${LOAM_FUZZ_SECONDS:-20}"
  echo "== clang determinism (the golden stamp sequence and refinement built with clang 14)"
  ninja -C build-fuzz stamp_golden_check
  ./build-fuzz/fuzz/stamp_golden_check
  end_phase "fuzz and clang checks"
fi
times=""
for i in "${!phase_names[@]}"; do times+="${phase_names[$i]} ${phase_secs[$i]} s, "; done
echo "== all tests passed (${times}total ${SECONDS} s)"
