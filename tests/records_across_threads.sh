#!/usr/bin/env bash
# Every quick study's records, fits included, are bit-identical at 1, 2 and 3 threads (run-time
# values aside: scripts/compare_records.py). Three, not two: an odd count splits every parallel
# loop and reduction differently from the even ones. The seed rule of docs/architecture.md:
# randomness from (seed, purpose, index) streams and sums in a fixed order, so the thread count
# cannot change a number.
#   records_across_threads.sh PLUMAGE SOURCE_DIR STUDY...   (STUDY: a studies/*.toml stem)
set -u
plumage=$1; source=$2; shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for threads in 1 2 3; do
  for study in "$@"; do
    if ! "$plumage" run "$source/studies/$study.toml" --out "$work/t$threads" --threads $threads \
         --no-plots >/dev/null 2>"$work/log"; then
      echo "FAIL: $study at $threads threads:"; cat "$work/log"; exit 1
    fi
  done
done
/usr/bin/python3 "$source/scripts/compare_records.py" "$work/t1" "$work/t2" || exit 1
/usr/bin/python3 "$source/scripts/compare_records.py" "$work/t1" "$work/t3"
