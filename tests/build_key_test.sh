#!/usr/bin/env bash
# The build's name (common/git_commit.cmake), which keys checkpoints: two builds of different
# uncommitted edits to one commit get different names, the same edit the same name, a clean
# tree the bare commit.
#   build_key_test.sh GIT_COMMIT_CMAKE
set -euo pipefail
script=$(realpath "$1")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
git init -q repo && cd repo
git config user.email test@example.org && git config user.name test
echo "a = 1" > source.txt && git add source.txt && git commit -qm one
name() {
  cmake -DGIT_EXECUTABLE="$(command -v git)" -DSOURCE_DIR="$PWD" -DOUTPUT="$work/out.cpp" \
    -P "$script" >/dev/null
  sed -n 's/.*return "\(.*\)";.*/\1/p' "$work/out.cpp"
}
clean=$(name)
echo "a = 2" > source.txt; first=$(name)
echo "a = 3" > source.txt; second=$(name)
echo "a = 2" > source.txt; again=$(name)
git checkout -q source.txt; back=$(name)
echo "clean $clean, edit A $first, edit B $second, edit A again $again, reverted $back"
[[ $clean != *dirty* && $first == "$clean"-dirty-* && $second == "$clean"-dirty-* ]]
[[ $first != "$second" && $first == "$again" && $back == "$clean" ]]
