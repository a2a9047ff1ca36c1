#!/usr/bin/env bash
# The command line against issue 43's smaller reproducers, run as a user would:
#   cli_inputs.sh PLUMAGE SOURCE_DIR CASE
# Each case prints what it saw and exits non-zero on the first broken promise. Each failed before
# the fix: command-line errors exited 104-109, nan was accepted, --threads 1000 under a memory
# limit aborted (134), a plotter that never returned blocked the run for ever.
set -u
plumage=$1; source=$2; case=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL ($case): $*"; exit 1; }
expect_two() {  # expect_two PATTERN ARGS...: exit 2, PATTERN in the message, nothing written
  local pattern=$1; shift
  message=$("$plumage" "$@" --out results 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "$*: exit $code, expected 2: $message"
  grep -q -- "$pattern" <<<"$message" || fail "$*: no '$pattern' in: $message"
  [[ ! -e results ]] || fail "$*: results were written"
}

case $case in
exit_codes)
  expect_two "not expected: --bogus" --bogus
  expect_two "STUDY is required" run
  expect_two "did you mean '--threads'" --threds 2 thin-film
  expect_two "expected a whole number of threads" --threads two thin-film
  ;;
not_a_number)
  expect_two "expected a number of seconds > 0" --time-budget nan thin-film
  expect_two "expected a number of seconds > 0" --time-budget inf thin-film
  expect_two "expected a fraction in \[0, 1\]" --target-error nan thin-film
  ;;
threads_memory)
  PLUMAGE_MEMORY_LIMIT_GB=1 expect_two "--threads 1000 (a stack of" --threads 1000 thin-film
  message=$(PLUMAGE_MEMORY_LIMIT_GB=1 "$plumage" --threads 1000 thin-film --out r 2>&1)
  grep -q "over the limit of 1 GB (PLUMAGE_MEMORY_LIMIT_GB" <<<"$message" || fail "$message"
  ;;
plot_timeout)
  # A plotter that answers the module probe, then never returns: stopped after the timeout, the
  # records and the report kept, exit 0.
  cat > python <<'PY'
#!/bin/sh
case "$*" in *find_spec*) echo ok; exit 0;; esac
exec sleep 1043
PY
  chmod +x python
  start=$(date +%s)
  message=$(PLUMAGE_PYTHON=$PWD/python PLUMAGE_PLOT_TIMEOUT_S=2 "$plumage" run \
            "$source/studies/masking_quick.toml" --out results 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  grep -q "stopped after 2 s (PLUMAGE_PLOT_TIMEOUT_S); the records and the report are kept" \
    <<<"$message" || fail "no timeout warning: $message"
  [[ -f results/masking_quick/masking.h5 && -f results/masking_quick/report.md ]] ||
    fail "records or report missing: $(ls -A results/masking_quick)"
  (( $(date +%s) - start < 120 )) || fail "took $(( $(date +%s) - start )) s"
  pgrep -f "sleep 1043" >/dev/null && fail "the plotter was left running"
  ;;
full_disk)
  # A results root on a 64 kB file system: exit 1 saying "No space left on device", nothing left
  # behind. Needs root to mount a tmpfs; skipped (exit 77) where that is refused.
  mkdir tiny
  mount -t tmpfs -o size=64k tmpfs tiny 2>/dev/null || { echo "skipped: cannot mount a tmpfs"; exit 77; }
  message=$("$plumage" run "$source/studies/masking_quick.toml" --out tiny/results --no-plots 2>&1)
  code=$?
  leftovers=$(find tiny/results -mindepth 1 2>/dev/null)
  umount tiny
  [[ $code -eq 1 ]] || fail "exit $code, expected 1: $message"
  grep -q "No space left on device" <<<"$message" || fail "no 'No space left on device': $message"
  [[ -z $leftovers ]] || fail "left behind: $leftovers"
  ;;
*)
  fail "unknown case"
  ;;
esac
echo "ok ($case)"
