#!/usr/bin/env bash
# The main job: set up, build, and run the default study (or the plumage command
# given as arguments, e.g. `scripts/run.sh thin-film --angle-step-deg 0.5`).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# Only what the main job needs (the binary and the Python module); scripts/test.sh builds the rest.
"$root/scripts/build.sh" plumage_main_job
exec "${PLUMAGE_BUILD_DIR:-$root/build}/studies/plumage" "$@"
