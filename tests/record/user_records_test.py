"""Records made by users (h5py, MATLAB) through `plumage fit` and `plumage.read_record`: well-formed
HDF5 with one field of the wrong type, shape or size is refused with exit 2, a message naming the
object and nothing written (virtual_gonio/record/hdf5_reader.h); a valid cone record is fitted with
progress and stops on Ctrl-C within 2 s.

Run by ctest as record.user_records (PLUMAGE_BINARY: the plumage executable; PYTHONPATH: the
built Python module).
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import plumage

PLUMAGE = os.environ["PLUMAGE_BINARY"]
STRING = h5py.string_dtype()


def write_scatterogram(path: Path, illumination: str = "beam", rows: int = 15,
                       wavelengths=(500.0, 600.0)) -> Path:
    """A valid imaging-scatterometer record (virtual_gonio/RECORD.md) whose image is Huang's
    model at the published parameters, with 3 % standard errors: a fit converges quickly."""
    n, nl = rows, len(wavelengths)
    pixel = 2.0 / n
    u = (np.arange(n) + 0.5) * pixel - 1.0
    uu, vv = np.meshgrid(u, -u)
    r = np.hypot(uu, vv)
    omega = np.where(r <= 1.0, 0.5 * np.pi * np.sin(0.5 * np.pi * r) / np.maximum(r, 1e-12), 0.0)
    omega *= pixel * pixel
    beam = np.array([np.sin(np.radians(20.0)), 0.0, np.cos(np.radians(20.0))])
    data = {"illumination": illumination, "beam_direction": beam,
            "cone_aperture_rad": np.radians(16.0), "wavelength_nm": np.array(wavelengths),
            "intensity": np.zeros((n, n, nl)), "standard_error": np.zeros((n, n, nl)),
            "solid_angle_sr": omega}
    image = np.asarray(plumage.models.huang2022_scatterogram({}, data)).reshape(n, n, nl)
    with h5py.File(path, "w") as f:
        inst = f.create_group("instrument")
        inst.attrs.create("kind", "imaging_scatterometer", dtype=STRING)
        inst.attrs.create("illumination", illumination, dtype=STRING)
        inst.attrs.create("beam_direction", " ".join(f"{x:.17g}" for x in beam), dtype=STRING)
        if illumination == "cone":
            inst.attrs["cone_aperture_deg"] = 16.0
        f["wavelength_nm"] = np.array(wavelengths)
        f["image/intensity"] = image
        f["image/standard_error"] = 0.03 * image + 1e-6 * (image > 0)
        f["image/solid_angle_sr"] = omega
        f.create_group("provenance").attrs.create("scatterer", "test", dtype=STRING)
    return path


def run_fit(record: Path, out: Path, model: str = "huang2022", timeout: float = 120.0):
    return subprocess.run([PLUMAGE, "fit", "--model", model, str(record), "--out", str(out),
                           "--no-plots", "--threads", "1"], capture_output=True, text=True,
                          timeout=timeout, cwd=out.parent)


def expect_refused(record: Path, tmp_path: Path, names: str, model: str = "huang2022"):
    out = tmp_path / "out"
    before = sorted(p.name for p in tmp_path.iterdir())
    result = run_fit(record, out, model)
    assert result.returncode == 2, (result.returncode, result.stderr)
    assert names in result.stderr, result.stderr
    assert str(record) in result.stderr, result.stderr
    assert not out.exists(), "nothing may be written for refused input"
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    # The Python reader refuses the same file with its own error, or reads it as it is.
    try:
        plumage.read_record(record)
    except plumage.records.RecordError:
        pass


def mutate(path: Path, change) -> Path:
    with h5py.File(path, "r+") as f:
        change(f)
    return path


# The cases: (id, the record's illumination, the change, the object the error names).
CASES = [
    ("kind_fixed_string_array", "beam",
     lambda f: f["instrument"].attrs.create("kind", np.array(["imaging_scatterometer"] * 1000,
                                                             dtype="S21")),
     "/instrument@kind"),
    ("kind_variable_string_array", "beam",
     lambda f: f["instrument"].attrs.create("kind", ["imaging_scatterometer"] * 1000, dtype=STRING),
     "/instrument@kind"),
    ("illumination_variable_string_array", "beam",
     lambda f: f["instrument"].attrs.create("illumination", ["beam"] * 2000, dtype=STRING),
     "/instrument@illumination"),
    ("beam_direction_fixed_string_array", "beam",
     lambda f: f["instrument"].attrs.create("beam_direction", np.array(["0 0 1"] * 64, dtype="S5")),
     "/instrument@beam_direction"),
    ("cone_aperture_array", "cone",
     lambda f: f["instrument"].attrs.create("cone_aperture_deg", np.full(4096, 16.0)),
     "/instrument@cone_aperture_deg"),
    ("beam_direction_of_length_1e-320", "beam",
     lambda f: f["instrument"].attrs.create("beam_direction", "0 0 1e-320", dtype=STRING),
     "/instrument@beam_direction"),
    ("missing_attribute", "beam", lambda f: f["instrument"].attrs.__delitem__("illumination"),
     "/instrument@illumination"),
    ("missing_kind", "beam", lambda f: f["instrument"].attrs.__delitem__("kind"),
     "/instrument@kind"),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_malformed_attribute_is_refused(tmp_path, case):
    _, illumination, change, names = case
    record = mutate(write_scatterogram(tmp_path / "user.h5", illumination), change)
    expect_refused(record, tmp_path, names)


def huge_declared(f, name, shape, chunks):
    """Replaces a dataset by one declaring a huge shape in many chunks, none written."""
    del f[name]
    f.create_dataset(name, shape=shape, chunks=chunks, dtype="f8")


@pytest.mark.parametrize("name,shape,chunks", [
    ("wavelength_nm", (30000 * 4096,), (4096,)),
    ("image/intensity", (4096, 4096, 30000), (64, 64, 64)),
    ("image/solid_angle_sr", (2 ** 31, 2 ** 31), (1024, 1024)),
])
def test_huge_declared_dataset_is_refused_before_allocation(tmp_path, name, shape, chunks):
    record = mutate(write_scatterogram(tmp_path / "user.h5"),
                    lambda f: huge_declared(f, name, shape, chunks))
    expect_refused(record, tmp_path, "/" + name)


@pytest.mark.parametrize("name,value,names", [
    ("wavelength_nm", np.array(["500", "600"], dtype="S3"), "/wavelength_nm"),
    ("image/solid_angle_sr", np.zeros((15, 15, 1)), "/image/solid_angle_sr"),
    ("wavelength_nm", np.array([500.0, np.nan]), "/wavelength_nm"),
    ("image/intensity", np.full((15, 15, 2), np.inf), "/image/intensity"),
])
def test_wrong_type_shape_or_value_is_refused(tmp_path, name, value, names):
    def change(f):
        del f[name]
        f[name] = value
    expect_refused(mutate(write_scatterogram(tmp_path / "user.h5"), change), tmp_path, names)


def test_external_link_is_not_followed(tmp_path):
    other = write_scatterogram(tmp_path / "other.h5")
    def change(f):
        del f["image/intensity"]
        f["image/intensity"] = h5py.ExternalLink(str(other), "/image/intensity")
    expect_refused(mutate(write_scatterogram(tmp_path / "user.h5"), change), tmp_path,
                   "/image/intensity")


def test_brdf_record_with_a_direction_below_the_patch_is_refused(tmp_path):
    record = tmp_path / "brdf.h5"
    with h5py.File(record, "w") as f:
        inst = f.create_group("instrument")
        inst.attrs.create("kind", "goniometer", dtype=STRING)
        w = np.tile([0.0, 0.0, 1.0], (4, 1))
        w[2] = [0.0, 0.6, -0.8]
        inst["light_directions"] = w
        inst["view_directions"] = np.tile([0.0, 0.0, 1.0], (4, 1))
        f["wavelength_nm"] = [550.0]
        f["brdf/value"] = np.ones((4, 1))
        f["brdf/standard_error"] = np.full((4, 1), 0.1)
    expect_refused(record, tmp_path, "/instrument/light_directions", model="filip2024")


def stop_with_ctrl_c(process, out: Path):
    """SIGINT to a running fit: exit 130 within 2 s, saying so, with nothing in --out."""
    process.send_signal(signal.SIGINT)
    sent = time.monotonic()
    try:
        code = process.wait(timeout=10)
    finally:
        process.kill()
    elapsed = time.monotonic() - sent
    rest = process.stderr.read()
    assert code == 130, (code, rest)
    assert elapsed < 2.0, f"stopped {elapsed:.2f} s after Ctrl-C"
    assert "interrupted" in rest
    assert not out.exists()


def test_valid_cone_record_is_fitted_with_progress_and_stops_on_ctrl_c(tmp_path):
    record = write_scatterogram(tmp_path / "cone.h5", "cone", rows=41, wavelengths=(450.0, 550.0,
                                                                                    650.0))
    out = tmp_path / "out"
    process = subprocess.Popen([PLUMAGE, "fit", "--model", "huang2022", str(record), "--out",
                                str(out), "--no-plots", "--threads", "1"],
                               stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    # The first line is the fit's cost ("one model evaluation …") once its first evaluation is
    # done, or, when that evaluation takes over 5 s (a sanitizer build runs about ten times
    # slower), a progress line from inside it: either way it speaks and says how to stop it.
    first = process.stderr.readline()
    assert "huang2022 fit:" in first, first
    assert "one model evaluation" in first or "evaluation 1:" in first, first
    assert "Ctrl-C stops it" in first
    stop_with_ctrl_c(process, out)


def test_slow_model_evaluation_reports_progress_within_it(tmp_path):
    """A hemisphere record of 64 × 64 pixels and 200 wavelengths: one model evaluation takes
    minutes on one thread. The fit must speak every 5 s from inside it (the structure-aware
    fuzzer's mutant 688 of seed 2027 spent 120 s in silence) and stop on Ctrl-C."""
    record = write_scatterogram(tmp_path / "hemisphere.h5", "hemisphere", rows=15,
                                wavelengths=(500.0,))
    with h5py.File(record, "r+") as f:
        n, wavelengths = 64, np.linspace(450.0, 649.0, 200)
        pixel = 2.0 / n
        u = (np.arange(n) + 0.5) * pixel - 1.0
        uu, vv = np.meshgrid(u, -u)
        r = np.hypot(uu, vv)
        omega = np.where(r <= 1.0, 0.5 * np.pi * np.sin(0.5 * np.pi * r) / np.maximum(r, 1e-12),
                         0.0) * pixel * pixel
        image = np.repeat(np.where(r <= 1.0, 0.1, 0.0)[:, :, None], len(wavelengths), axis=2)
        for name in ("wavelength_nm", "image/intensity", "image/standard_error",
                     "image/solid_angle_sr"):
            del f[name]
        f["wavelength_nm"] = wavelengths
        f["image/intensity"] = image
        f["image/standard_error"] = 0.03 * image + 1e-6 * (image > 0)
        f["image/solid_angle_sr"] = omega
    out = tmp_path / "out"
    process = subprocess.Popen([PLUMAGE, "fit", "--model", "huang2022", str(record), "--out",
                                str(out), "--no-plots", "--threads", "1"],
                               stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    started = time.monotonic()
    first = process.stderr.readline()
    waited = time.monotonic() - started
    assert "huang2022 fit:" in first and "Ctrl-C stops it" in first, first
    assert waited < 15.0, f"first progress line after {waited:.1f} s"
    stop_with_ctrl_c(process, out)


def test_valid_beam_record_is_fitted(tmp_path):
    record = write_scatterogram(tmp_path / "beam.h5")
    result = run_fit(record, tmp_path / "out")
    assert result.returncode == 0, result.stderr
    assert "huang2022 fit:" in result.stderr
    assert (tmp_path / "out" / "fit_huang2022_beam" / "parameters.json").exists()
