#!/usr/bin/env bash
# Issue 19: a study's records are the same to the bit whether it runs in one process (no
# launcher) or under `mpirun -np N` for N = 1, 2, 3, with 1 or 2 threads per rank (run-time
# values aside: scripts/compare_records.py). Three ranks, not two: an odd count deals the
# chunks differently from the even ones.
#   records_across_ranks.sh PLUMAGE SOURCE_DIR MPIEXEC STUDY...   (STUDY: a studies/*.toml stem)
set -u
plumage=$1; source=$2; mpiexec=$3; shift 3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The ranks' scratch folders (and Open MPI's session folder) go here, to be checked at the end.
export TMPDIR="$work/tmp"
mkdir -p "$TMPDIR"
# More ranks than cores on a CI machine; as root (containers) Open MPI needs to be told.
launch=("$mpiexec" --oversubscribe)
[[ $(id -u) -eq 0 ]] && launch+=(--allow-run-as-root)
for study in "$@"; do
  if ! "$plumage" run "$source/studies/$study.toml" --out "$work/plain" --threads 1 --no-plots \
       >/dev/null 2>"$work/log"; then
    echo "FAIL: $study without a launcher:"; cat "$work/log"; exit 1
  fi
done
status=0
# A scratch folder of a rank this host cannot see (another container or PID namespace sharing
# the temporary folder: its pid means nothing here, and it has no owner record we could judge)
# must survive every run; before owner records, a rank removed any whose pid was not running.
foreign="$TMPDIR/plumage-scratch-$(hostname)-4194303"  # no such pid here
mkdir -p "$foreign" && echo "another namespace's rank" > "$foreign/keep.txt"
for setup in "1 1" "2 1" "3 1" "1 2" "2 2"; do
  read -r ranks threads <<<"$setup"
  out="$work/np${ranks}_t${threads}"
  for study in "$@"; do
    start=$EPOCHREALTIME
    if ! "${launch[@]}" -np "$ranks" "$plumage" run "$source/studies/$study.toml" --out "$out" \
         --threads "$threads" --no-plots >/dev/null 2>"$work/log"; then
      echo "FAIL: $study at $ranks ranks x $threads threads:"; cat "$work/log"; exit 1
    fi
    awk -v s="$start" -v e="$EPOCHREALTIME" -v what="$study at $ranks rank(s) x $threads thread(s)" \
      'BEGIN { printf "%s: %.1f s\n", what, e - s }'
  done
  if ! /usr/bin/python3 "$source/scripts/compare_records.py" "$work/plain" "$out"; then
    echo "FAIL: records at $ranks ranks x $threads threads differ from the single process's"
    status=1
  fi
done
# The foreign folder kept; no rank left its own scratch results root behind.
[[ -f $foreign/keep.txt ]] || { echo "FAIL: another namespace's scratch folder was removed"; status=1; }
rm -rf "$foreign"
for d in "$TMPDIR"/plumage-scratch-*; do
  [[ -e $d ]] && { echo "FAIL: scratch folder left: $d"; status=1; }
done
exit $status
