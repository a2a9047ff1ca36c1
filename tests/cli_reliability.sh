#!/usr/bin/env bash
# The command line against issue 13's reproducers, run exactly as a user would:
#   cli_reliability.sh PLUMAGE SOURCE_DIR CASE
# Each case prints what it saw and exits non-zero on the first broken promise.
set -u
plumage=$1; source=$2; case=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL ($case): $*"; exit 1; }

case $case in
absolute_name)
  # Reproducer 1: an absolute study name used to replace (and delete) the folder it named.
  mkdir victim && echo precious > victim/keep.txt
  sed "s|^name = .*|name = \"$PWD/victim\"|" "$source/studies/ablation_quick.toml" > abs.toml
  message=$("$plumage" run abs.toml --out results --threads 2 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "exit $code, expected 2: $message"
  grep -q "abs.toml:5:8: name = \"$PWD/victim\"" <<<"$message" || fail "message names no file:line:col: $message"
  [[ "$(cat victim/keep.txt)" == precious ]] || fail "victim/keep.txt is gone"
  [[ ! -e results ]] || fail "results were written: $(ls -A results)"
  ;;
foreign_folder)
  # A folder the user owns, of the study's name, is refused before any work and kept.
  mkdir -p results/masking_quick && echo mine > results/masking_quick/notes.txt
  message=$("$plumage" run "$source/studies/masking_quick.toml" --out results 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "exit $code, expected 2: $message"
  grep -q "was not written by plumage" <<<"$message" || fail "$message"
  [[ "$(cat results/masking_quick/notes.txt)" == mine ]] || fail "the user's file is gone"
  ;;
orphan)
  # Reproducer 4: a staging folder left by a killed run is removed by the next run.
  sleep 0 & gone=$!; wait $gone
  mkdir -p "results/masking_quick.partial-$gone" && touch "results/masking_quick.partial-$gone/.plumage-results"
  message=$("$plumage" run "$source/studies/masking_quick.toml" --out results --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  [[ ! -e "results/masking_quick.partial-$gone" ]] || fail "the orphan survived"
  grep -q "removed .*masking_quick.partial-$gone, left by process $gone which is gone" <<<"$message" || fail "not said: $message"
  ;;
tiny_step)
  # Reproducer 2: step_nm = 1e-320 used to allocate until out of memory.
  sed "s|^step_nm = .*|step_nm = 1e-320|" "$source/studies/rock_dove_quick.toml" > tiny.toml
  message=$("$plumage" run tiny.toml --out results 2>&1); code=$?
  [[ $code -eq 2 ]] || fail "exit $code, expected 2: $message"
  grep -q "tiny.toml:17:11: spectrum.step_nm = .*expected at most 4701" <<<"$message" || fail "$message"
  ;;
plot_failure)
  # Reproducer 5: a plot that fails no longer loses the study.
  message=$(PLUMAGE_PYTHON=/nonexistent/python3 "$plumage" run "$source/studies/masking_quick.toml" --out results 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  [[ -f results/masking_quick/masking.h5 && -f results/masking_quick/report.md ]] || fail "records or report missing"
  grep -q "warning: masking.png not drawn: cannot run the interpreter /nonexistent/python3" <<<"$message" || fail "$message"
  ;;
options_after_subcommand)
  # --out, --threads and --no-plots after the subcommand (geometry used to exit 109).
  message=$("$plumage" geometry "$source/studies/geometry/rock_dove_row.toml" --out R --threads 2 --no-plots 2>&1); code=$?
  [[ $code -eq 0 ]] || fail "exit $code: $message"
  [[ -f R/rock_dove_row/report.md ]] || fail "no R/rock_dove_row/report.md"
  help=$("$plumage" run --help 2>&1)
  for option in --out --threads --time-budget --target-error --no-plots; do
    grep -q -- "$option" <<<"$help" || fail "run --help does not list $option"
  done
  ;;
messages)
  # Short, named messages for misspellings and wrong values.
  message=$("$plumage" --threads two 2>&1); code=$?
  [[ $code -ne 0 && ${#message} -lt 300 ]] || fail "exit $code, ${#message} characters: $message"
  grep -q "expected a whole number of threads" <<<"$message" || fail "$message"
  message=$("$plumage" runn x.toml 2>&1)
  grep -q "did you mean 'run'" <<<"$message" || fail "$message"
  message=$("$plumage" run x.toml --treads 2 2>&1)
  grep -q "did you mean '--threads'" <<<"$message" || fail "$message"
  message=$("$plumage" run "$source/studies/geometry/rock_dove_row.toml" 2>&1); code=$?
  [[ $code -eq 2 ]] && grep -q "plumage geometry" <<<"$message" || fail "exit $code: $message"
  message=$("$plumage" geometry "$source/studies/masking_quick.toml" 2>&1); code=$?
  [[ $code -eq 2 ]] && grep -q "plumage run" <<<"$message" || fail "exit $code: $message"
  message=$("$plumage" run "$source/studies/masking_quick.toml" --time-budget 5 2>&1); code=$?
  [[ $code -eq 2 ]] && grep -q "do not apply to the masking study" <<<"$message" || fail "exit $code: $message"
  ;;
*) fail "unknown case" ;;
esac
echo "ok: $case"
