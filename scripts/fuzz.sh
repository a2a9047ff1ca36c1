#!/usr/bin/env bash
# Fuzzes every parser a user feeds (docs/fuzzing.md): builds the libFuzzer targets with clang,
# ASan and UBSan in build-fuzz/, then runs each on a copy of its committed corpus.
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 60 s; all targets)
# Prints inputs tried, crashes, timeouts and leaks per target; exits 1 on any finding, whose
# input stays in build-fuzz/artifacts/<target>/ (commit it to fuzz/corpus/<target>/ once fixed:
# the replay tests then keep it fixed).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
seconds=${1:-60}
shift || true
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=(study ply obj vdb record)

"$root/scripts/install-deps.sh"
if ! command -v clang++ >/dev/null || ! ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then
  apt-get update >&2 && apt-get install -y --no-install-recommends clang >&2
fi
build=${PLUMAGE_FUZZ_BUILD_DIR:-$root/build-fuzz}
export CCACHE_BASEDIR=$root CCACHE_NOHASHDIR=true
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DPLUMAGE_FUZZ=ON -DPLUMAGE_BUILD_TESTS=OFF -DPLUMAGE_BUILD_BENCHMARKS=OFF >&2
fi
start=$(date +%s)
cmake --build "$build" --parallel "${PLUMAGE_JOBS:-2}" --target $(printf 'plumage_fuzz_%s ' "${targets[@]}") >&2
echo "fuzz build: $(( $(date +%s) - start )) s"

status=0
printf '%-8s %10s %8s %8s %8s %6s\n' target inputs seconds crashes timeouts leaks
for target in "${targets[@]}"; do
  work=$(mktemp -d)
  cp -r "$root/fuzz/corpus/$target/." "$work/"
  artifacts="$build/artifacts/$target/"
  rm -rf "$artifacts" && mkdir -p "$artifacts"  # this run's findings only
  log="$build/fuzz_$target.log"
  set +e
  # -timeout: an input that takes 10 s is a hang; -rss_limit_mb: a parser must not need 4 GB.
  ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS="suppressions=$root/scripts/lsan.supp:print_suppressions=0" \
    "$build/fuzz/plumage_fuzz_$target" "$work" -max_total_time="$seconds" \
    -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 -artifact_prefix="$artifacts" >"$log" 2>&1
  code=$?
  set -e
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  crashes=$(ls "$artifacts" | grep -c '^crash-' || true)
  timeouts=$(ls "$artifacts" | grep -c '^timeout-' || true)
  leaks=$(ls "$artifacts" | grep -c '^leak-' || true)
  ooms=$(ls "$artifacts" | grep -c '^oom-' || true)
  printf '%-8s %10s %8s %8s %8s %6s\n' "$target" "${runs:-0}" "$seconds" "$((crashes + ooms))" "$timeouts" "$leaks"
  if [[ $code -ne 0 ]]; then
    status=1
    echo "  finding: see $log and $artifacts" >&2
    grep -m3 -E 'ERROR|SUMMARY|terminate|runtime error' "$log" >&2 || true
  fi
  rm -rf "$work"
done
exit $status
