#!/usr/bin/env bash
# Every quick study's records are bit-identical at 1 and 2 threads (run-time values aside:
# scripts/compare_records.py). DESIGN.md's rule: randomness from (seed, purpose, index)
# streams and sums in a fixed order, so the thread count cannot change a number.
#   records_across_threads.sh PLUMAGE SOURCE_DIR STUDY...   (STUDY: a studies/*.toml stem)
set -u
plumage=$1; source=$2; shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for threads in 1 2; do
  for study in "$@"; do
    if ! "$plumage" run "$source/studies/$study.toml" --out "$work/t$threads" --threads $threads \
         --no-plots >/dev/null 2>"$work/log"; then
      echo "FAIL: $study at $threads threads:"; cat "$work/log"; exit 1
    fi
  done
done
/usr/bin/python3 "$source/scripts/compare_records.py" "$work/t1" "$work/t2"
