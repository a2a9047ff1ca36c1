#!/usr/bin/env bash
# Issue 35 (acceptance 4): the full-wave far field of one case (full_wave_ranks.cpp) through
# Meep's MPI build at 1 and 2 ranks, and through the serial build, within 1e-9 relative; and a
# stop flag set on one rank only ends the run on both (no rank left stepping: a deadlock would
# hit the timeout here).
#   full_wave_across_ranks.sh SERIAL_PROGRAM MPI_PROGRAM MPIEXEC
set -u
serial=$1; mpi=$2; mpiexec=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export TMPDIR="$work"  # Open MPI's session folder
# More ranks than free cores on a shared machine; as root (containers) Open MPI must be told.
launch=("$mpiexec" --oversubscribe)
[[ $(id -u) -eq 0 ]] && launch+=(--allow-run-as-root)
"$serial" 1 "$work/serial.txt" || { echo "FAIL: the serial build"; exit 1; }
for ranks in 1 2; do
  # one OpenMP thread per rank: the ranks share the machine's cores
  if ! OMP_NUM_THREADS=1 "${launch[@]}" -np "$ranks" "$mpi" "$ranks" "$work/np$ranks.txt"; then
    echo "FAIL: the MPI build at $ranks rank(s)"; exit 1
  fi
done
status=0
if ! timeout 120 env OMP_NUM_THREADS=1 "${launch[@]}" -np 2 "$mpi" 2 --stop; then
  echo "FAIL: a stop flag set on rank 1 alone did not end the run on both ranks"; status=1
fi
echo "MPI build, 1 rank against 2 ranks:"
"$mpi" --compare "$work/np1.txt" "$work/np2.txt" || status=1
echo "serial build against the MPI build at 1 rank:"
"$mpi" --compare "$work/serial.txt" "$work/np1.txt" || status=1
exit $status
