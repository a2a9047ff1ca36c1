#!/usr/bin/env bash
# `cmake --install` into a fresh prefix gives a plumage that runs from there (its shared
# libraries found through its RPATH, not the build tree), the study files and the documents,
# and CITATION.cff names the version being built.
#   install_test.sh BUILD_DIR PROJECT_VERSION
set -u
build=$1; version=$2
prefix=$(mktemp -d)
trap 'rm -rf "$prefix"' EXIT
if ! cmake --install "$build" --prefix "$prefix/x" >"$prefix/log" 2>&1; then
  echo "FAIL: cmake --install:"; cat "$prefix/log"; exit 1
fi
# The build tree must not be what makes it run.
out=$(cd / && env -u LD_LIBRARY_PATH "$prefix/x/bin/plumage" --version 2>&1) || {
  echo "FAIL: installed plumage --version: $out"; exit 1; }
[[ $out == "plumage $version"* ]] || { echo "FAIL: --version printed '$out'"; exit 1; }
for f in share/plumage/studies/rock_dove.toml share/plumage/studies/geometry/rock_dove_row.toml \
         share/doc/plumage/README.md share/doc/plumage/LICENSE share/doc/plumage/CITATION.cff \
         share/plumage/tests/reference/barbule_2d/far_field.csv; do
  [[ -f $prefix/x/$f ]] || { echo "FAIL: $f not installed"; exit 1; }
done
# CITATION.cff cites the version CMakeLists.txt builds.
grep -qx "version: $version" "$prefix/x/share/doc/plumage/CITATION.cff" || {
  echo "FAIL: CITATION.cff's version is not $version (CMakeLists.txt's project version)"; exit 1; }
if ldd "$prefix/x/bin/plumage" | grep -q "$build"; then
  echo "FAIL: the installed plumage loads libraries from the build tree:"
  ldd "$prefix/x/bin/plumage" | grep "$build"; exit 1
fi
echo "install: $out runs from $prefix/x"
