#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds Plumage (Release, with
# ccache when present) in ${PLUMAGE_BUILD_DIR:-build}: every target, or only the CMake targets
# named as arguments (scripts/run.sh builds `plumage_main_job`: the binary and the Python module).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/install-deps.sh"
build_dir=${PLUMAGE_BUILD_DIR:-$root/build}
# ccache keys on paths relative to the checkout, so a fresh clone elsewhere (CI) reuses the
# objects of an earlier build instead of compiling CGAL and OpenVDB code again (~25 min).
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root}
export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-true}
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [[ ! -f "$build_dir/CMakeCache.txt" ]]; then
  cmake -S "$root" -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release >&2
fi
# Two jobs: the machines we target have 2 cores; more only thrashes.
targets=()
for target in "$@"; do targets+=(--target "$target"); done
cmake --build "$build_dir" --parallel "${PLUMAGE_JOBS:-2}" "${targets[@]}" >&2
# `import plumage` in /usr/bin/python3 from this build (python/): a path file, no copy.
if [[ -d "$build_dir/python/plumage" ]]; then
  "$root/scripts/install_python_path.sh" "$build_dir"
fi
