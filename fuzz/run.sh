#!/usr/bin/env bash
# Builds (if needed) and runs libFuzzer targets for a fixed time each.
#   fuzz/run.sh TARGET SECONDS     e.g. fuzz/run.sh wire_fuzz 30
#   fuzz/run.sh all SECONDS        every fuzz/*_fuzz.cpp, JOBS (default: the cores) at a time
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
# `all` also builds the clang golden check (scripts/test.sh runs it next) in the same ninja run,
# where its compile shares the cores with the targets'.
extra=()
if [[ $1 == all ]]; then extra=(stamp_golden_check); fi
ninja -C "$build" -j "${JOBS:-2}" "${targets[@]}" "${extra[@]}"

# detect_leaks stays on: a leak on a decode path is a bug too.
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
artifacts=$root/fuzz/corpus-work/artifacts
mkdir -p "$artifacts"
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT

# One target for its full SECONDS; its output goes to $logs/TARGET.log.
fuzz_one() {
  local target=$1 seeds=$root/fuzz/corpus/$1 work=$root/fuzz/corpus-work/$1
  [[ -d $seeds ]] || { echo "no seed corpus at $seeds"; return 2; }
  mkdir -p "$work"
  "$build/fuzz/$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=70000 \
    -print_final_stats=1 -artifact_prefix="$artifacts/$target-" "$work" "$seeds"
}

# Each libFuzzer process is single-threaded: JOBS targets run side by side, each for the full
# SECONDS (the fuzzing each gets is the same as one after another; the wall time is not).
jobs=${JOBS:-$(nproc)}
declare -A pid_target=()
failed=0
report() {  # prints a finished target's log and verdict
  local target=$1 rc=$2
  echo "== fuzz $target for ${seconds}s"
  cat "$logs/$target.log"
  if [[ $rc -ne 0 ]]; then
    echo "FUZZ FAILURE: $target exited with $rc; reproducer in $artifacts/" >&2
    failed=$rc
  else
    echo "fuzz: $target ran ${seconds}s without a finding"
  fi
}
wait_one() {
  local done_pid rc=0
  wait -n -p done_pid "${!pid_target[@]}" || rc=$?
  report "${pid_target[$done_pid]}" "$rc"
  unset "pid_target[$done_pid]"
}
for target in "${targets[@]}"; do
  while [[ ${#pid_target[@]} -ge $jobs ]]; do wait_one; done
  fuzz_one "$target" >"$logs/$target.log" 2>&1 &
  pid_target[$!]=$target
done
while [[ ${#pid_target[@]} -gt 0 ]]; do wait_one; done
exit "$failed"
