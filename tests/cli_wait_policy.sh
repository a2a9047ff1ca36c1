#!/usr/bin/env bash
# Issue 41: idle OpenMP threads sleep (OMP_WAIT_POLICY=passive) unless the user chose how they
# wait (common/omp_wait_policy.h): spinning ones made --threads 2 slower than --threads 1 when
# another process held a core. libgomp reads the variable when it loads, so plumage sets it and
# executes itself again; this checks what the OpenMP runtime of the running study finally saw
# (libgomp prints it with OMP_DISPLAY_ENV=verbose, once per start), that the arguments survived
# the second start and the process kept its name, and that one thread and the user's own
# choices start only once.
#   cli_wait_policy.sh PLUMAGE
# Exit 77 (skipped) when the OpenMP runtime is not libgomp (no GOMP_SPINCOUNT in its display).
set -u
plumage=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
# spin_counts ENV... -- ARGS...: the GOMP_SPINCOUNT values libgomp displayed, one per start.
# The study file does not exist: the run stops with exit 2 naming it, after the wait policy.
spin_counts() {
  local -a vars=()
  while [[ $1 != -- ]]; do vars+=("$1"); shift; done
  shift
  env -u OMP_WAIT_POLICY -u GOMP_SPINCOUNT "${vars[@]}" OMP_DISPLAY_ENV=verbose \
    "$plumage" "$@" run "$work/missing.toml" >"$work/out" 2>&1
  code=$?
  [[ $code -eq 2 ]] || fail "$*: exit $code, expected 2 (bad input): $(cat "$work/out")"
  grep -q "missing.toml" "$work/out" || fail "$*: the error does not name the file: $(cat "$work/out")"
  sed -n "s/.*GOMP_SPINCOUNT = '\([0-9]*\)'.*/\1/p" "$work/out" | tr '\n' ' '
}
counts=$(spin_counts -- --threads 2)
[[ -n $counts ]] || { echo "skipped: the OpenMP runtime is not libgomp"; exit 77; }
# libgomp's default (300000 spins), then the second start with passive (0 spins).
[[ $counts == "300000 0 " ]] || fail "--threads 2: spin counts '$counts', expected '300000 0 '"
counts=$(spin_counts -- --threads 0)
[[ $counts == "300000 0 " ]] || fail "--threads 0: spin counts '$counts', expected '300000 0 '"
# One thread waits for nobody: no second start.
counts=$(spin_counts -- --threads 1)
[[ $counts == "300000 " ]] || fail "--threads 1: spin counts '$counts', expected '300000 ' (one start)"
# The user's choices win, and need no second start.
counts=$(spin_counts OMP_WAIT_POLICY=active -- --threads 2)
[[ $counts == "30000000000 " ]] || fail "OMP_WAIT_POLICY=active: spin counts '$counts'"
counts=$(spin_counts GOMP_SPINCOUNT=1000 -- --threads 2)
[[ $counts == "1000 " ]] || fail "GOMP_SPINCOUNT=1000: spin counts '$counts'"
# The second start keeps the process's name (ps, top and pgrep show plumage), and a SIGTERM
# that comes while it loads waits for its handler (exit 143, not killed by the signal): a study,
# watched until its environment has the variable (the second start has begun), then stopped.
env -u OMP_WAIT_POLICY -u GOMP_SPINCOUNT "$plumage" --threads 2 --no-plots --out "$work/study" \
  run "$(dirname "$0")/../studies/species_quick.toml" >/dev/null 2>&1 &
pid=$!
for ((i = 0; i < 3000; i++)); do
  tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -q -x OMP_WAIT_POLICY=passive && break
  sleep 0.01
done
name=$(cat "/proc/$pid/comm" 2>/dev/null)
passive=$(tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -c -x OMP_WAIT_POLICY=passive)
kill -TERM "$pid" 2>/dev/null
wait "$pid"
code=$?
[[ $passive -eq 1 ]] || fail "the running study has no OMP_WAIT_POLICY=passive after 30 s"
[[ $name == "$(basename "$plumage")" ]] || fail "the process is named '$name' after its second start"
[[ $code -eq 143 ]] || fail "SIGTERM during the second start: exit $code, expected 143"
echo "ok"
