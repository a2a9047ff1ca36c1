#!/usr/bin/env bash
# The main job: set up, build, and run the default study (or the plumage command
# given as arguments, e.g. `scripts/run.sh thin-film --angle-step-deg 0.5`).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/build.sh"
exec "${PLUMAGE_BUILD_DIR:-$root/build}/studies/plumage" "$@"
