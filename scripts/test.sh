#!/usr/bin/env bash
# The tests: set up, build, and run the whole GoogleTest suite through CTest.
# Extra arguments go to ctest (e.g. `scripts/test.sh -R ThinFilm`).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/build.sh"
cd "${PLUMAGE_BUILD_DIR:-$root/build}"
ctest --output-on-failure --parallel "${PLUMAGE_JOBS:-2}" "$@"
