#!/usr/bin/env bash
# The whole test suite under AddressSanitizer and UndefinedBehaviorSanitizer, in the instrumented
# build it shares with scripts/fuzz.sh (scripts/instrumented-build.sh: clang, no recovery, frame
# pointers kept). Arguments go to ctest, e.g. `scripts/sanitize.sh -L fast`.
#   PLUMAGE_JOBS=N: parallel compile jobs and tests (default 2).
# Prints how long the build and the tests took.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
jobs=${PLUMAGE_JOBS:-2}
start=$(date +%s)
build=$("$root/scripts/instrumented-build.sh")
built=$(date +%s)
# Leaks are checked. scripts/lsan.supp names the third-party allocations that are not ours
# (OpenVDB and HDF5 on damaged files), each with its reason; our code is never suppressed.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$root/scripts/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
cd "$build"
set +e
nice ctest --output-on-failure --parallel "$jobs" "$@"
code=$?
set -e
echo "sanitizer suite: build $((built - start)) s, tests $(($(date +%s) - built)) s, exit $code"
exit $code
