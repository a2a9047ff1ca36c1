#!/usr/bin/env bash
# The whole test suite under AddressSanitizer and UndefinedBehaviorSanitizer, in its own build
# folder (build-sanitize/, GCC). Arguments go to ctest, e.g. `scripts/sanitize.sh -L fast`.
# Prints how long the build and the tests took.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/install-deps.sh"
build=${PLUMAGE_SANITIZE_BUILD_DIR:-$root/build-sanitize}
export CCACHE_BASEDIR=$root CCACHE_NOHASHDIR=true
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DPLUMAGE_SANITIZE=address,undefined -DPLUMAGE_BUILD_BENCHMARKS=OFF >&2
fi
start=$(date +%s)
cmake --build "$build" --parallel "${PLUMAGE_JOBS:-2}" >&2
built=$(date +%s)
# Leaks are checked; OpenMP's and TBB's worker pools are process-lifetime allocations that
# the runtime frees at exit, not leaks of ours (lsan.supp says which).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$root/scripts/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
cd "$build"
set +e
ctest --output-on-failure --parallel "${PLUMAGE_JOBS:-2}" "$@"
code=$?
set -e
echo "sanitizer suite: build $((built - start)) s, tests $(( $(date +%s) - built )) s, exit $code"
exit $code
