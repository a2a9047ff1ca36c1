#!/usr/bin/env bash
# scripts/check-references.py fails, naming file and line, on a comment that points outside the
# repository (the notes' names are assembled here so that this file passes the check itself).
#   check_references_catches.sh CHECK_SCRIPT
set -u
check=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/sim" "$work/build-x"
printf '// Fine.\n// Patch frame (%s.md): +z normal.\n' "DESIGN" > "$work/sim/frame.h"
printf '# see ../%s/papers/x.txt\n' "shared" > "$work/build-x/ignored.sh"  # build folders: not scanned
if out=$(/usr/bin/python3 "$check" "$work"); then
  echo "check-references passed a file that cites the design notes:"; echo "$out"; exit 1
fi
echo "$out"
grep -q '^sim/frame.h:2: ' <<<"$out" || { echo "expected sim/frame.h:2 in the report"; exit 1; }
if grep -q 'ignored.sh' <<<"$out"; then echo "a build folder was scanned"; exit 1; fi
printf '// Patch frame (sim/scatterer/scatterer.h): +z normal.\n' > "$work/sim/frame.h"
/usr/bin/python3 "$check" "$work" || { echo "check-references failed a clean tree"; exit 1; }
