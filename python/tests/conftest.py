"""Shared fixtures: records made by the built plumage binary in a temporary folder.

ctest sets PLUMAGE_BINARY, PLUMAGE_SOURCE_DIR and PYTHONPATH (python/CMakeLists.txt); run by
hand: PYTHONPATH=build/python PLUMAGE_BINARY=build/studies/plumage /usr/bin/python3 -m pytest
python/tests
"""

import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(
    os.environ.get("PLUMAGE_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


def _binary() -> pathlib.Path:
    binary = pathlib.Path(os.environ.get("PLUMAGE_BINARY", SOURCE_DIR / "build/studies/plumage"))
    if not binary.exists():
        pytest.fail(f"no plumage binary at {binary}: build first (scripts/build.sh) or set "
                    "PLUMAGE_BINARY")
    return binary


def run_study(study_text: str, out: pathlib.Path, name: str) -> pathlib.Path:
    study = out / f"{name}.toml"
    study.write_text(study_text)
    subprocess.run([str(_binary()), "run", str(study), "--out", str(out), "--no-plots",
                    "--threads", "2"], check=True, capture_output=True, text=True)
    return out / name


@pytest.fixture(scope="session")
def rock_dove_results(tmp_path_factory) -> pathlib.Path:
    """The quick rock-dove study (goniometer and scatterometer records; ~15 s)."""
    text = (SOURCE_DIR / "studies/rock_dove_quick.toml").read_text()
    text = text.replace('name = "rock_dove_quick"', 'name = "py_rock_dove"')
    return run_study(text, tmp_path_factory.mktemp("rock_dove"), "py_rock_dove")


@pytest.fixture(scope="session")
def species_results(tmp_path_factory) -> pathlib.Path:
    """The quick species study, rooster only (a BTF record)."""
    text = (SOURCE_DIR / "studies/species_quick.toml").read_text()
    text = text.replace('name = "species_quick"', 'name = "py_species"')
    text = text.replace('run = "parrot, rooster, flamingo, stork"', 'run = "rooster"')
    return run_study(text, tmp_path_factory.mktemp("species"), "py_species")
