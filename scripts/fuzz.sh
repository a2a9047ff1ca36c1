#!/usr/bin/env bash
# Fuzzes every parser a user feeds (docs/reliability.md, "Fuzzing"): builds the libFuzzer targets
# (clang, ASan, UBSan) in the instrumented build it shares with scripts/sanitize.sh
# (scripts/instrumented-build.sh), then runs each on a copy of its committed corpus.
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]   (default $PLUMAGE_FUZZ_SECONDS or 60 s;
#                                                       targets: study ply obj vdb record bsdf;
#                                                       not by default: structure)
#   PLUMAGE_JOBS=N: parallel compile jobs (default 2).
# `structure` is not a libFuzzer target: fuzz/structure/fuzz_user_data.py makes well-formed HDF5
# records, CSV tables and .bsdf files with the wrong types, shapes, values and links (h5py) and
# runs them through the instrumented `plumage fit`, plumage.read_record and the .bsdf replay
# harness. It counts mutants, not seconds: PLUMAGE_STRUCTURE_FUZZ_COUNT (default 2000; about
# 40 a minute in a Release build, several times fewer under ASan), PLUMAGE_STRUCTURE_FUZZ_SEED
# (1), PLUMAGE_STRUCTURE_FUZZ_TIMEOUT (s per run, default 300: ASan fits run about ten times
# slower than the Release build's 60 s limit allows). read_record and the seeds use the Python
# module of the Release build (build/python, scripts/build.sh; PLUMAGE_STRUCTURE_PYTHON_PATH):
# an ASan extension cannot be imported into /usr/bin/python3.
# Prints per target the inputs tried, crashes, hangs (inputs over 10 s), leaks, out-of-memory
# and files written outside the fuzzer's temporary folder; exits 1 on any finding, whose input
# stays in build-instrumented/artifacts/<target>/ (once fixed, commit it to
# fuzz/regressions/<target>/: the replay tests then keep it fixed). The repository is never
# modified.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
seconds=${1:-${PLUMAGE_FUZZ_SECONDS:-60}}
shift || true
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=(study ply obj vdb record bsdf)

start=$(date +%s)
build_targets=()
for target in "${targets[@]}"; do
  if [[ $target == structure ]]; then
    build_targets+=(plumage plumage_replay_bsdf)
  else
    build_targets+=("plumage_fuzz_$target")
  fi
done
build=$("$root/scripts/instrumented-build.sh" "${build_targets[@]}")
echo "fuzz build: $(($(date +%s) - start)) s"

count() { find "$1" -maxdepth 1 -name "$2-*" | wc -l; }
status=0
printf '%-7s %10s %8s %8s %6s %6s %5s %8s\n' target execs seconds crashes hangs leaks ooms written
for target in "${targets[@]}"; do
  if [[ $target == structure ]]; then
    # Structure-aware (fuzz/structure/fuzz_user_data.py): its own empty folders and TMPDIR per
    # run; "execs" are mutants, "written" files outside the fit's --out folder.
    python_path=${PLUMAGE_STRUCTURE_PYTHON_PATH:-$root/build/python}
    if ! ls "$python_path"/plumage/_core*.so >/dev/null 2>&1; then
      echo "structure: no plumage Python module in $python_path (run scripts/build.sh, or set" \
        "PLUMAGE_STRUCTURE_PYTHON_PATH)" >&2
      status=1
      continue
    fi
    work=$(mktemp -d)
    artifacts="$build/artifacts/$target"
    rm -rf "$artifacts" && mkdir -p "$artifacts"
    log="$build/fuzz_$target.log"
    began=$(date +%s)
    set +e
    ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
      LSAN_OPTIONS="suppressions=$root/scripts/lsan.supp:print_suppressions=0" \
      /usr/bin/python3 "$root/fuzz/structure/fuzz_user_data.py" --plumage "$build/studies/plumage" \
      --bsdf-reader "$build/fuzz/plumage_replay_bsdf" --python-path "$python_path" \
      --count "${PLUMAGE_STRUCTURE_FUZZ_COUNT:-2000}" --seed "${PLUMAGE_STRUCTURE_FUZZ_SEED:-1}" \
      --timeout "${PLUMAGE_STRUCTURE_FUZZ_TIMEOUT:-300}" --jobs 2 --work "$work" \
      --findings "$artifacts" --summary-json "$work/summary.json" >"$log" 2>&1
    code=$?
    set -e
    if [[ -f $work/summary.json ]]; then
      read -r execs crashes hangs leaks written < <(/usr/bin/python3 -c '
import json, sys
s = json.load(open(sys.argv[1]))
print(s["mutants"], s["crash"] + s["unclean"] + s["unnamed"] + s["no_output"], s["hang"],
      s["leak"], s["written"])' "$work/summary.json")
    else
      execs=0 crashes=0 hangs=0 leaks=0 written=0
    fi
    # crashes: signals, sanitizer reports, unclean exits, exit 2 not naming the file, no output
    printf '%-7s %10s %8s %8s %6s %6s %5s %8s\n' "$target" "$execs" "$(($(date +%s) - began))" \
      "$crashes" "$hangs" "$leaks" 0 "$written"
    if [[ $code -ne 0 ]]; then
      status=1
      echo "  finding: see $log (its table) and $artifacts/" >&2
      grep -m5 -E '^- ' "$log" >&2 || true
    fi
    rm -rf "$work"
    continue
  fi
  # The corpus is copied (libFuzzer adds to it); the target runs in an empty folder with its own
  # TMPDIR, so anything it writes besides its temporary input shows up below.
  work=$(mktemp -d)
  mkdir "$work/corpus" "$work/cwd" "$work/tmp"
  cp -r "$root/fuzz/corpus/$target/." "$work/corpus/"
  artifacts="$build/artifacts/$target"
  rm -rf "$artifacts" && mkdir -p "$artifacts"  # this run's findings only
  dict=()
  [[ -f "$root/fuzz/$target.dict" ]] && dict=(-dict="$root/fuzz/$target.dict")
  log="$build/fuzz_$target.log"
  began=$(date +%s)
  set +e
  # -timeout: an input taking 10 s is a hang; -rss_limit_mb: a parser must not need 4 GB.
  # -fork=1 with -ignore_*: findings inside third-party readers (OpenVDB, HDF5) come within
  # seconds, so each finding is kept and the fuzzer carries on for the whole time.
  # A single allocation larger than memory (a size read from a damaged file) must fail as it
  # does in a normal build, with std::bad_alloc, which the reader turns into an InputError:
  # allocator_may_return_null and a malloc limit above ASan's own 1 TB cap; memory actually
  # used still counts against -rss_limit_mb.
  (cd "$work/cwd" &&
    TMPDIR="$work/tmp" ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
    LSAN_OPTIONS="suppressions=$root/scripts/lsan.supp:print_suppressions=0" \
    "$build/fuzz/plumage_fuzz_$target" "$work/corpus" "${dict[@]}" \
      -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -malloc_limit_mb=2000000 \
      -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
      -artifact_prefix="$artifacts/") >"$log" 2>&1
  code=$?
  set -e
  # Inputs tried: the fork driver's tally ("#N: cov: ...") at its last finished job.
  execs=$(grep -oE '^#[0-9]+: cov' "$log" | tail -1 | tr -dc '0-9' || true)
  crashes=$(($(count "$artifacts" crash) + $(count "$artifacts" deadly)))
  # A finding leaves its input in TMPDIR (the process died holding it): not a write.
  written=$(find "$work/cwd" "$work/tmp" -mindepth 1 ! -name 'plumage_fuzz_*' \
    ! -path '*/libFuzzerTemp*' | wc -l)
  printf '%-7s %10s %8s %8s %6s %6s %5s %8s\n' "$target" "${execs:-0}" "$(($(date +%s) - began))" \
    "$crashes" "$(count "$artifacts" timeout)" "$(count "$artifacts" leak)" \
    "$(count "$artifacts" oom)" "$written"
  if [[ $code -ne 0 || $written -ne 0 ]]; then
    status=1
    echo "  finding: see $log and $artifacts/" >&2
    grep -m3 -E 'ERROR|SUMMARY|terminate|runtime error' "$log" >&2 || true
  fi
  rm -rf "$work"
done
exit $status
