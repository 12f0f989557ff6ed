#!/usr/bin/env bash
# Builds (if needed) and runs libFuzzer targets for a fixed time each.
#   fuzz/run.sh TARGET SECONDS     e.g. fuzz/run.sh wire_fuzz 30
#   fuzz/run.sh all SECONDS        every fuzz/*_fuzz.cpp, one after another
# Exits non-zero on any crash, sanitizer report, timeout or property violation; the input
# that triggered it is left in fuzz/corpus-work/artifacts/ (git-ignored). The committed seed
# corpus fuzz/corpus/TARGET/ is only read; new inputs go to fuzz/corpus-work/TARGET/.
# Environment: BUILD_DIR (default build-fuzz), CXX/CC (default clang++-14/clang-14), JOBS.
set -euo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 TARGET|all SECONDS   (targets: fuzz/*_fuzz.cpp)" >&2
  exit 2
fi
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${BUILD_DIR:-$root/build-fuzz}
seconds=$2
if [[ $1 == all ]]; then
  targets=()
  for src in "$root"/fuzz/*_fuzz.cpp; do targets+=("$(basename "$src" .cpp)"); done
else
  targets=("$1")
fi

if [[ ! -f $build/build.ninja ]]; then
  cmake -S "$root" -B "$build" -G Ninja \
    -DCMAKE_CXX_COMPILER="${CXX:-clang++-14}" -DCMAKE_C_COMPILER="${CC:-clang-14}" \
    -DLOAM_FUZZ=ON -DLOAM_SANITIZE=ON
fi
ninja -C "$build" -j "${JOBS:-2}" "${targets[@]}"

# detect_leaks stays on: a leak on a decode path is a bug too.
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
artifacts=$root/fuzz/corpus-work/artifacts
mkdir -p "$artifacts"
for target in "${targets[@]}"; do
  seeds=$root/fuzz/corpus/$target
  work=$root/fuzz/corpus-work/$target
  [[ -d $seeds ]] || { echo "no seed corpus at $seeds" >&2; exit 2; }
  mkdir -p "$work"
  echo "== fuzz $target for ${seconds}s"
  set +e
  "$build/fuzz/$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=70000 \
    -print_final_stats=1 -artifact_prefix="$artifacts/$target-" "$work" "$seeds"
  rc=$?
  set -e
  if [[ $rc -ne 0 ]]; then
    echo "FUZZ FAILURE: $target exited with $rc; reproducer in $artifacts/" >&2
    exit "$rc"
  fi
  echo "fuzz: $target ran ${seconds}s without a finding"
done
