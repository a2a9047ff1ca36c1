#!/usr/bin/env bash
# A bad study file must make plumage exit non-zero (2: bad input) with a message that
# names file:line and what was expected, and leave no results folder behind.
#   cli_bad_study.sh PLUMAGE PATTERN ARGS...   (ARGS include the study file)
set -u
plumage=$1; pattern=$2; shift 2
out=$(mktemp -d)
message=$("$plumage" --out "$out/results" "$@" 2>&1 >/dev/null)
code=$?
status=0
if [[ $code -ne 2 ]]; then echo "expected exit code 2, got $code"; status=1; fi
if ! grep -Eq -- "$pattern" <<<"$message"; then echo "message does not match '$pattern': $message"; status=1; fi
if [[ -e "$out/results" ]] && [[ -n "$(ls -A "$out/results")" ]]; then
  echo "a results folder was left behind: $(ls -A "$out/results")"; status=1
fi
rm -rf "$out"
[[ $status -eq 0 ]] && echo "ok: exit $code, $message"
exit $status
