#!/usr/bin/env bash
# python.venv_install: `pip install .` in a fresh venv (no system site packages), then `import
# plumage` from outside the source tree and the pytest suite with that venv's interpreter.
# CI is offline, so numpy, h5py, pytest and matplotlib (examples/huang_fit.py, which the suite
# runs) come from wheels of Debian's installed packages (scripts/debian_wheelhouse.py); the venv
# is made from the same interpreter, whose ABI they were built for. The wheel is built in the
# backend's build folder (python/build_backend); nothing else is written into the source tree.
# Usage: venv_install.sh PYTHON SOURCE_DIR PLUMAGE_BINARY
set -euo pipefail
python=$1 source_dir=$2 binary=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
venv=$work/venv

if ! "$python" -m venv "$venv"; then
  echo "venv_install: '$python -m venv' failed (Debian: apt-get install python3-venv)" >&2
  exit 1
fi
"$python" "$source_dir/scripts/debian_wheelhouse.py" "$work/wheels" numpy h5py pytest matplotlib
# No cache in the user's home, no version check against PyPI, one compile job (ctest runs tests
# beside this one), nothing on PYTHONPATH: only the venv's own site-packages count.
unset PYTHONPATH
export PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PLUMAGE_JOBS=1 PYTHONDONTWRITEBYTECODE=1
start=$(date +%s)
"$venv/bin/python" -m pip install --quiet --no-index --find-links "$work/wheels" \
  "${source_dir}[test]" matplotlib
echo "venv_install: pip install took $(($(date +%s) - start)) s"

cd "$work"  # not the source tree: `import plumage` must find the installed package
"$venv/bin/python" - "$venv" <<'PYTHON'
import pathlib, sys
import numpy as np
import plumage

venv = pathlib.Path(sys.argv[1]).resolve()
where = pathlib.Path(plumage.__file__).resolve()
assert venv in where.parents, f"plumage imported from {where}, not from the venv {venv}"
assert sys.prefix != sys.base_prefix and not any("dist-packages" in p for p in sys.path), sys.path
# The compiled module at work: a quarter-wave keratin film in air at normal incidence reflects
# ((1 - n²)/(1 + n²))² (Airy's closed form), a half-wave one nothing (an absentee layer).
n = float(plumage.optics.keratin([550.0]).real[0])
quarter, half = plumage.optics.thin_film_reflectance(np.array([0.25, 0.5]) * 0.55 / n, 550.0)
expected = ((1 - n**2) / (1 + n**2)) ** 2
assert abs(quarter - expected) < 1e-12 and abs(half) < 1e-12, (quarter, expected, half)
print(f"venv_install: plumage from {where.parent}; quarter-wave keratin film R = {quarter:.6f}")
PYTHON
PLUMAGE_BINARY=$binary PLUMAGE_SOURCE_DIR=$source_dir \
  "$venv/bin/python" -m pytest -q -p no:cacheprovider "$source_dir/python/tests"
