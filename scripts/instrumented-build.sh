#!/usr/bin/env bash
# The one instrumented build that scripts/sanitize.sh and scripts/fuzz.sh share: clang, ASan and
# UBSan (no recovery, frame pointers kept), libFuzzer coverage on every object, tests on,
# RelWithDebInfo, in ${PLUMAGE_INSTRUMENTED_BUILD_DIR:-build-instrumented}. One build instead of
# two: on 2 cores a cold instrumented build of the tree takes about half an hour.
#   instrumented-build.sh [TARGET...]   builds these targets (all when none); prints the folder.
#   PLUMAGE_JOBS=N: parallel compile jobs (default 2).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/install-deps.sh" >&2
# libFuzzer's runtime is in libclang-rt-14-dev, which Debian 12's clang only recommends.
if ! command -v clang++ >/dev/null ||
  ! ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then
  apt-get update >&2 && apt-get install -y --no-install-recommends clang libclang-rt-14-dev >&2
fi
build=${PLUMAGE_INSTRUMENTED_BUILD_DIR:-$root/build-instrumented}
# ccache (picked up by CMakeLists.txt when present) keyed on checkout-relative paths.
export CCACHE_BASEDIR=$root CCACHE_NOHASHDIR=true
# Whole-study tests run about ten times slower under ASan: their timeouts are scaled to match.
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DPLUMAGE_FUZZ=ON -DPLUMAGE_BUILD_TESTS=ON -DPLUMAGE_BUILD_BENCHMARKS=OFF \
    -DPLUMAGE_TEST_TIMEOUT_SCALE=10 >&2
else
  cmake -S "$root" -B "$build" -DPLUMAGE_TEST_TIMEOUT_SCALE=10 >/dev/null
fi
targets=()
[[ $# -gt 0 ]] && targets=(--target "$@")
nice cmake --build "$build" --parallel "${PLUMAGE_JOBS:-2}" "${targets[@]}" >&2
echo "$build"
